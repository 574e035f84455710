"""Where the interpreted PID and ADRC spend a call: the layers of the hot path, peeled.

Each layer is timed alone, in one process, against simple-pid and pyadrc in the
same run: every round times each layer and the peer once, back to back, and the
ratio of that round is taken; the result is the median over ``--rounds`` rounds (on a
shared machine the load moves between rounds, less within one; quote ratios, not
nanoseconds):

* ``law``: the one law every executor runs (``pid.pid_law`` with the options off,
  ``adrc.adrc_law`` with the Euler ESO), called with its arguments ready;
* ``kernel``: the law and its commit (``pid_step``, the compiled kernels' cycle, which
  the PID's fast lane runs as its two calls; the ADRC's ``_fast_cycle``: the law and
  its state);
* ``body``: the block's ``_call`` -- the lane's admission test (modes, first cycle,
  inputs finite, sample time), the kernel, the outputs it writes;
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
from ctrlblocks.blocks.adrc import NO_ANTI_BACKOFF, NO_EXACT, adrc_law
from ctrlblocks.blocks.pid import NO_OPTIONS, pid_law, pid_step


def _ns(fn: Callable[[], object], n: int = 20_000) -> float:
    return timeit.timeit(fn, number=n) / n * 1e9


def _rounds(fns: dict[str, Callable[[], object]], rounds: int) -> dict[str, tuple[float, float]]:
    """Per layer: (median over the rounds of its time / the peer's in the same round, median ns)."""
    ratios: dict[str, list[float]] = {name: [] for name in fns}
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(rounds):
        t = {name: _ns(fn) for name, fn in fns.items()}
        for name in fns:
            ratios[name].append(t[name] / t["peer"])
            times[name].append(t[name])
    return {name: (statistics.median(ratios[name]), statistics.median(times[name])) for name in fns}


def pid_layers(rounds: int) -> dict[str, tuple[float, float]]:
    import simple_pid

    p = PID(kp=2.0, ti=5.0, td=0.5, ts=0.1, u_min=0.0, u_max=100.0)
    p(1.0, 0.99)
    prm = p._prm
    peer = simple_pid.PID(2.0, 0.4, 1.0, setpoint=1.0, sample_time=None, output_limits=(0, 100))
    return _rounds({
        "law": lambda: pid_law(1.0, 0.99, 0.0, False, 0.0, False, False, False, False, False,
                               0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 50.0, 50.0,
                               prm, NO_OPTIONS),
        "kernel": lambda: pid_step(1.0, 0.99, 0.0, False, 0.0, False, False, 0.0, 0.0, 0.0, 0.0,
                                   50.0, prm),
        "body": lambda: p._call(1.0, 0.99, 0.0, 0.0, None, True),
        "call": lambda: p(1.0, 0.99),
        "peer": lambda: peer(0.99, dt=0.1),
    }, rounds)  # fmt: skip


def adrc_layers(rounds: int) -> dict[str, tuple[float, float]]:
    import pyadrc

    a = ADRC(order=2, b0=0.05, omega_c=0.5, omega_o=2.5, ts=0.1, u_min=0.0, u_max=100.0)
    for _ in range(50):
        a(1.0, 0.99)
    prm = a._kernel_params()
    peer = pyadrc.StateSpace(order=2, delta=0.1, b0=0.05, w_cl=0.5, k_eso=5)
    return _rounds({
        "law": lambda: adrc_law(1.0, 0.99, 0.0, False, 20.0, False, True, 0, False, False, False,
                                0.99, 0.0, 0.0, 0.0, 20.0, 20.0, 1.0, 0.0, 0, 0.0, prm, NO_EXACT,
                                NO_ANTI_BACKOFF),
        "kernel": lambda: a._fast_cycle(1.0, 0.99),
        "body": lambda: a._call(1.0, 0.99, True, True, None, None, 0.0),
        "call": lambda: a(1.0, 0.99),
        "peer": lambda: peer(0.99, 20.0, 1.0),
    }, rounds)  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    for name, layers, peer in (("PID", pid_layers, "simple-pid"), ("ADRC", adrc_layers, "pyadrc")):
        t = layers(args.rounds)
        print(f"{name} (interpreted), per call, ratio to one {peer} call:")
        for layer in ("law", "kernel", "body", "call"):
            print(f"  {layer:<7} {t[layer][0]:5.2f}x   ({t[layer][1]:7.0f} ns)")
        print(f"  {peer:<10} 1.00x   ({t['peer'][1]:7.0f} ns)", flush=True)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
