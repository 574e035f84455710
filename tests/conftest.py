"""The whole suite: which blocks it tests.

The interpreted blocks are the reference, so the suite runs them unless
``$CTRLBLOCKS_COMPILED`` says otherwise, even on a machine where ``ctrlblocks
compile`` has made a build.  ``CTRLBLOCKS_COMPILED=require`` runs the same tests
against the compiled build (README, "Compiled blocks"); tests/blocks/test_compiled.py
then also checks that it really is the one loaded.
"""

import os

os.environ.setdefault("CTRLBLOCKS_COMPILED", "off")
