"""The verdict of ``ctrlblocks compare`` against a brute force on the TRUE process.

Processes of known models (tests/sim/processes.py: FOPDT, SOPDT, reverse
acting, dead-time dominant, lag dominant, noisy; and held-out ones from a seeded
generator no method was tuned on) give a noisy bump test; ``compare`` sees only
that record.  The oracle (tests/sim/brute_force.py) searches each family's
parameters on the true process by a grid and a zoom (screened by frequency
responses, the best judged one by one with the real block), at the same Ms and
MV-noise budget, and says which family tracks and which rejects the load
better.  The verdict must agree, or say tie: a family it names may not lose on
the true process by more than the tie band.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ctrlblocks.sim.compare import compare
from tests.sim import brute_force as bf
from tests.sim.processes import NAMED, Process, held_out


def _judge(p: Process, tmp_path, *, ts: float | None = None) -> dict:
    t, u, y = p.bump()
    s = compare(t, u, y, tmp_path, corners=False, ts=ts, levels=())
    sigma = p.noise * abs(p.truth.gain)  # the true PV noise of the record (du = 1)
    o = bf.Oracle(p.truth, s["ts"], s["ms_target"], sigma, s["mv_noise_max"], s["step"],
                  abs(s["load"]))  # fmt: skip
    pid, adrc = bf.best_pid(o), bf.best_adrc(o)
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


def test_the_oracles_screen_reads_the_blocks_as_linear_in_their_gains():
    """The search's shortcut: a PID's C_y = kp C_PD + ki C_I and C_r = b kp + ki C_I for a
    fixed (td, N), an ADRC's C_r and C_y proportional to 1/b0 -- against the real blocks."""
    from ctrlblocks.blocks.adrc import ADRC
    from ctrlblocks.blocks.pid import PID
    from ctrlblocks.tuning.identify import FOPDT

    o = bf.Oracle(FOPDT(1.5, 20.0, 4.0), 0.5, 1.6, 0.0, math.inf, 1.0, 0.5)
    one = {"kp": 1.0, "ts": 0.5, **bf.UNLIMITED}
    cr_p, cy_pd = o.responses(PID(td=3.0, n=5.0, **one))
    cr_pi, cy_pi = o.responses(PID(ti=1.0, **one))
    cr_0, cy_0 = o.responses(PID(**one))
    kp, ki, b = 2.3, 0.07, 0.4
    cr, cy = o.responses(PID(kp=kp, ti=kp / ki, td=3.0, n=5.0, b=b, ts=0.5, **bf.UNLIMITED))
    assert abs(cy - (kp * cy_pd + ki * (cy_pi - cy_0))).max() <= 1e-9 * abs(cy).max()
    assert abs(cr - (b * kp * cr_p + ki * (cr_pi - cr_0))).max() <= 1e-9 * abs(cr).max()
    for order in (1, 2, 3):
        kw = {"order": order, "omega_c": 0.2, "omega_o": 1.0, "ts": 0.5, "input_delay": 2.0}
        cr1, cy1 = o.responses(ADRC(b0=1.0, **kw))
        cr7, cy7 = o.responses(ADRC(b0=7.0, **kw))
        # pointwise, but for the rounding of the integrator's pole near z = 1 (1e-8 measured)
        assert np.all(abs(cy7 * 7.0 - cy1) <= 1e-6 * abs(cy1))
        assert np.all(abs(cr7 * 7.0 - cr1) <= 1e-6 * abs(cr1))


def test_the_oracles_response_equals_the_loop_simulated_step_by_step():
    from ctrlblocks.blocks.adrc import ADRC
    from ctrlblocks.tuning.identify import FOPDT
    from ctrlblocks.tuning.margins import Loop

    lp = Loop(FOPDT(1.5, 20.0, 4.0), ADRC(order=2, b0=0.05, omega_c=0.3, omega_o=1.5, ts=0.1))
    _t, y, _u = lp.simulate(300.0, r=1.0, load=0.3)
    assert max(abs(a - b) for a, b in zip(y, bf.response(lp, 300.0, r=1.0, load=0.3),
                                          strict=True)) < 1e-6  # fmt: skip


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_the_verdict_agrees_with_the_true_process_on_a_dead_time_process(tmp_path):
    """A coarse sample time: FOPDT with the
    dead time as long as half the lag, 1 % noise."""
    from ctrlblocks.tuning.identify import FOPDT

    p = Process("fopdt L/T 0.5", FOPDT(1.0, 10.0, 5.0), 0.01, 11)
    r = _judge(p, tmp_path, ts=0.5)
    assert all(math.isfinite(v) for case in r["truth"].values() for v in case[:2])


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("p", NAMED, ids=[p.name for p in NAMED])
def test_the_verdict_agrees_with_the_true_process_on_the_named_kinds(p, tmp_path):
    _judge(p, tmp_path)


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("p", held_out(4), ids=lambda p: p.name)
def test_the_verdict_agrees_with_the_true_process_on_held_out_processes(p, tmp_path):
    """Processes from a seeded generator (gain, lag, dead time, second lag, noise drawn)
    that no design choice was tuned on."""
    _judge(p, tmp_path)
