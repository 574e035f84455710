"""The verdict of ``ctrlblocks compare`` against a brute force on the TRUE process.

Processes of known models (tests/sim/processes.py: FOPDT, SOPDT, reverse
acting, dead-time dominant, lag dominant, noisy; and held-out ones from a seeded
generator no method was tuned on) give a noisy bump test; ``compare`` sees only
that record.  The oracle (tests/sim/brute_force.py) searches each family's
parameters on the true process by a grid and Nelder-Mead, at the same Ms and
MV-noise budget, and says which family tracks and which rejects the load
better.  The verdict must agree, or say tie: a family it names may not lose on
the true process by more than the tie band.
"""

from __future__ import annotations

import math

import pytest

from ctrlblocks.sim.compare import compare
from tests.sim import brute_force as bf
from tests.sim.processes import NAMED, Process, held_out


def _judge(p: Process, tmp_path, *, fine: bool, ts: float | None = None) -> dict:
    t, u, y = p.bump()
    s = compare(t, u, y, tmp_path, corners=False, ts=ts, levels=())
    sigma = p.noise * abs(p.truth.gain)  # the true PV noise of the record (du = 1)
    o = bf.Oracle(p.truth, s["ts"], s["ms_target"], sigma, s["mv_noise_max"], s["step"],
                  abs(s["load"]))  # fmt: skip
    pid, adrc = bf.best_pid(o, fine=fine), bf.best_adrc(o, fine=fine)
    out = {"summary": s, "truth": {}}
    for case in ("setpoint", "load"):
        tp, ta = pid[case].iae, adrc[case].iae
        out["truth"][case] = (tp, ta, bf.winner(tp, ta, s["tie"]))
        print(f"{p.name} {case}: compare {s['winners'][case]}, true process PID "
              f"{pid[case].name} {tp:.4g}, ADRC {adrc[case].name} {ta:.4g}")
        said = s["winners"][case]
        assert bf.agrees(said, tp, ta, s["tie"]), (
            f"{p.name}, {case}: compare says {said} ({s['winners']['best'][case]}), the true "
            f"process says best PID {pid[case].name} {tp:.4g}, best ADRC {adrc[case].name} "
            f"{ta:.4g}"
        )
    return out


def test_the_oracles_response_equals_the_loop_simulated_step_by_step():
    from ctrlblocks.blocks.adrc import ADRC
    from ctrlblocks.tuning.identify import FOPDT
    from ctrlblocks.tuning.margins import Loop

    lp = Loop(FOPDT(1.5, 20.0, 4.0), ADRC(order=2, b0=0.05, omega_c=0.3, omega_o=1.5, ts=0.1))
    _t, y, _u = lp.simulate(300.0, r=1.0, load=0.3)
    assert max(abs(a - b) for a, b in zip(y, bf.response(lp, 300.0, r=1.0, load=0.3),
                                          strict=True)) < 1e-6  # fmt: skip


@pytest.mark.timeout(900)
def test_the_verdict_agrees_with_the_true_process_on_a_dead_time_process(tmp_path):
    """The default run's one process (coarse oracle, a coarse sample time): FOPDT with the
    dead time as long as half the lag, 1 % noise."""
    from ctrlblocks.tuning.identify import FOPDT

    p = Process("fopdt L/T 0.5", FOPDT(1.0, 10.0, 5.0), 0.01, 11)
    r = _judge(p, tmp_path, fine=False, ts=0.5)
    assert all(math.isfinite(v) for case in r["truth"].values() for v in case[:2])


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("p", NAMED, ids=[p.name for p in NAMED])
def test_the_verdict_agrees_with_the_true_process_on_the_named_kinds(p, tmp_path):
    _judge(p, tmp_path, fine=True)


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("p", held_out(4), ids=lambda p: p.name)
def test_the_verdict_agrees_with_the_true_process_on_held_out_processes(p, tmp_path):
    """Processes from a seeded generator (gain, lag, dead time, second lag, noise drawn)
    that no design choice was tuned on."""
    _judge(p, tmp_path, fine=True)
