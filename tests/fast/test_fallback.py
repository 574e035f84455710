"""Without numba every fast path runs the same functions interpreted, with the same numbers."""

from __future__ import annotations

import json
import os
import subprocess
import sys

SCRIPT = (
    """
import json, logging
import numpy as np
logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
"""
    + (
        BODY := """
from ctrlblocks import PID
from ctrlblocks.fast import HAVE_NUMBA, PIDBank, closed_loop
from ctrlblocks.plants import PTn
pid = PID(kp=2.0, ti=8.0, td=1.0, ts=0.1, u_min=0.0, u_max=1.5)
res = closed_loop(pid, PTn(k=0.73, t=(7.3, 2.2, 1.4), ts=0.1), sp=1.0, n=300)
bank = PIDBank.from_arrays(kp=[2.0, 3.0], ti=[8.0, 5.0], td=0.5, ts=0.1, u_max=1.5,
                           plant_k=0.73, plant_t=[[7.3, 2.2, 1.4], [4.0, 2.0, 1.0]])
b = bank.run(1.0, 300)
out = {"numba": HAVE_NUMBA, "path": res.path, "y": res.y[-1], "u": res.u[-1],
       "bank_y": b.y.tolist()}
"""
    )
    + "print(json.dumps(out))\n"
)


def _run_without_numba() -> tuple[dict, str]:
    env = dict(os.environ, CTRLBLOCKS_NO_NUMBA="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         env=env, check=True, timeout=120)  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1]), out.stderr


def test_fallback_without_numba_runs_interpreted_and_says_so():
    got, log = _run_without_numba()
    assert got["numba"] is False and got["path"] == "python"
    assert "run interpreted" in log
    scope: dict = {}
    exec(BODY, scope)  # the same script here, compiled when numba is installed
    ref = scope["out"]
    assert got["y"] == ref["y"] and got["u"] == ref["u"]
    assert got["bank_y"] == ref["bank_y"]
    assert 0.9 < got["y"] < 1.1  # the loop does control
