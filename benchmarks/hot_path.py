"""Where the interpreted PID and ADRC spend a call: the layers of the hot path, peeled.

Each layer is timed alone, in one process, against simple-pid and pyadrc in the
same run (medians of ``--rounds`` rounds; quote ratios, not nanoseconds):

* ``law``: the one law every executor runs (``pid.pid_law`` with the options off,
  ``adrc.adrc_law`` with the Euler ESO), called with its arguments ready;
* ``kernel``: the whole auto cycle as the compiled kernels run it (``pid_step``: the
  law and its commit; ``adrc_step``: the law with the ADRC's state), its result a tuple;
* ``body``: the block's ``_call`` -- the lane's admission test (modes, first cycle,
  inputs finite, sample time), the law and its commit, the outputs and state it writes;
* ``call``: ``block(sp, pv)`` -- the input conversion and the output guard around it.

Run with ``CTRLBLOCKS_COMPILED=off`` (the default here) for the interpreted blocks:
``python benchmarks/hot_path.py [--rounds 9]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import timeit
from collections.abc import Callable

os.environ.setdefault("CTRLBLOCKS_COMPILED", "off")

from ctrlblocks import ADRC, PID
from ctrlblocks.blocks.adrc import NO_ANTI_BACKOFF, NO_EXACT, adrc_law, adrc_step
from ctrlblocks.blocks.pid import NO_OPTIONS, pid_law, pid_step


def _ns(fn: Callable[[], object], rounds: int, n: int = 20_000) -> float:
    return statistics.median(timeit.repeat(fn, number=n, repeat=rounds)) / n * 1e9


def pid_layers(rounds: int) -> dict[str, float]:
    import simple_pid

    p = PID(kp=2.0, ti=5.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
    p(1.0, 0.99)
    prm = p._prm
    peer = simple_pid.PID(2.0, 0.4, 1.0, setpoint=1.0, sample_time=None, output_limits=(0, 100))
    return {
        "law": _ns(lambda: pid_law(1.0, 0.99, 0.0, False, 0.0, False, False, False, False, False,
                                   0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 50.0, 50.0,
                                   prm, NO_OPTIONS), rounds),
        "kernel": _ns(lambda: pid_step(1.0, 0.99, 0.0, False, 0.0, False, False, 0.0, 0.0, 0.0,
                                       0.0, 50.0, prm), rounds),
        "body": _ns(lambda: p._call(1.0, 0.99, 0.0, 0.0, None, True), rounds),
        "call": _ns(lambda: p(1.0, 0.99), rounds),
        "peer": _ns(lambda: peer(0.99, dt=0.1), rounds),
    }


def adrc_layers(rounds: int) -> dict[str, float]:
    import pyadrc

    a = ADRC(order=2, b0=0.05, omega_c=0.5, omega_o=2.5, ts=0.1, u_min=0.0, u_max=100.0)
    for _ in range(50):
        a(1.0, 0.99)
    prm = a._kernel_params()
    peer = pyadrc.StateSpace(order=2, delta=0.1, b0=0.05, w_cl=0.5, k_eso=5)
    return {
        "law": _ns(lambda: adrc_law(1.0, 0.99, 0.0, False, 20.0, False, True, 0, False, False,
                                    False, 0.99, 0.0, 0.0, 0.0, 20.0, 20.0, 1.0, 0.0, 0, 0.0, prm,
                                    NO_EXACT, NO_ANTI_BACKOFF), rounds),
        "kernel": _ns(lambda: adrc_step(1.0, 0.99, False, 20.0, True, False, 0, 0.99, 0.0, 0.0,
                                        0.0, 20.0, 1.0, 0.0, prm), rounds),
        "body": _ns(lambda: a._call(1.0, 0.99, True, True, None, None, 0.0), rounds),
        "call": _ns(lambda: a(1.0, 0.99), rounds),
        "peer": _ns(lambda: peer(0.99, 20.0, 1.0), rounds),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    for name, layers, peer in (("PID", pid_layers, "simple-pid"), ("ADRC", adrc_layers, "pyadrc")):
        t = layers(args.rounds)
        print(f"{name} (interpreted), per call, ratio to one {peer} call:")
        for layer in ("law", "kernel", "body", "call"):
            print(f"  {layer:<7} {t[layer] / t['peer']:5.2f}x   ({t[layer]:7.0f} ns)")
        print(f"  {peer:<10} 1.00x   ({t['peer']:7.0f} ns)", flush=True)


if __name__ == "__main__":
    main()
