"""``python -m ctrlblocks.testing``: the long fuzz campaign (:func:`ctrlblocks.testing.main`)."""

import sys

from . import main

sys.exit(main())
