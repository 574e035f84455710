"""Test-session settings shared by every test directory."""

from __future__ import annotations

import os

# the suite's processes compile kernels with numba (cached on disk) instead of building
# their native modules (ahead of time, slower to build); tests/fast/test_native.py builds one
os.environ.setdefault("CTRLBLOCKS_NATIVE", "0")
