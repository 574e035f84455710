"""The PID's integral band (conditional integration, Åström & Hägglund 2006, section 3.5).

The option lives in the one law (``pid_law``): the block, its float32 cycle and
the exported function block get it from there; the compiled kernels refuse it
(their law runs without options).
"""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks import PID, ErrorCode, ParameterError
from ctrlblocks.fast import closed_loop
from ctrlblocks.plants import PTn


def test_the_error_is_integrated_only_inside_the_band_hand_computed() -> None:
    """PI K = 2, Ti = 1 s, h = 0.1 s, Tustin: K h/(2 Ti) = 0.1 per unit of e[k-1] + e[k]."""
    pid = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, i_band=5.0)
    assert pid(10.0, 0.0) == 20.0  # P = 2 * 10; the first cycle integrates nothing
    assert pid(10.0, 0.0) == 20.0  # |e| = 10 > 5: no increment (without the band 22)
    assert pid(10.0, 7.0) == pytest.approx(6.0 + 0.1 * (10.0 + 3.0), abs=1e-12)  # inside
    assert pid(10.0, 7.0) == pytest.approx(6.0 + 1.3 + 0.1 * (3.0 + 3.0), abs=1e-12)
    assert pid(10.0, -10.0) == pytest.approx(40.0 + 1.9, abs=1e-12)  # outside again: held
    assert pid.error_id == ErrorCode.NO_ERROR


def test_without_a_band_the_law_is_unchanged() -> None:
    a = PID(kp=2.0, ti=3.0, td=0.5, ts=0.1)
    b = PID(kp=2.0, ti=3.0, td=0.5, ts=0.1, i_band=0.0)
    rng = np.random.default_rng(3)
    for pv in rng.normal(0.0, 5.0, 200):
        assert a(1.0, pv) == b(1.0, pv)


def test_the_velocity_form_freezes_its_integral_increments_outside_the_band() -> None:
    pos = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, i_band=5.0)
    vel = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, i_band=5.0,
              algorithm="velocity")  # fmt: skip
    for pv in (0.0, 0.0, 7.0, 7.0, 8.0, -10.0, -10.0, 9.0):
        assert vel(10.0, pv) == pytest.approx(pos(10.0, pv), abs=1e-9)


def _step_response(i_band: float) -> np.ndarray:
    """PI (K = 2, Ti = 4 s) on 1/(5 s + 1)^2, the setpoint stepped 0 -> 50 % (300 s)."""
    pid = PID(kp=2.0, ti=4.0, ts=0.1, u_min=0.0, u_max=100.0, i_band=i_band)
    return closed_loop(pid, PTn(k=1.0, t=(5.0, 5.0), ts=0.1), sp=np.full(3000, 50.0)).y


def test_a_band_lowers_the_overshoot_of_a_large_setpoint_step() -> None:
    """The integral grows only near the setpoint, so the overshoot is lower (Åström &
    Hägglund 2006, section 3.5) and the loop still settles on the setpoint: the band
    (20 %) is wider than the error the P action alone leaves, 50/(1 + 2) = 16.7 %."""
    plain, banded = _step_response(0.0), _step_response(20.0)
    assert plain.max() - 50.0 > 5.0  # a real overshoot without the band
    assert banded.max() - 50.0 < 0.5 * (plain.max() - 50.0)
    assert banded[-1] == pytest.approx(50.0, abs=0.05)


def test_a_band_narrower_than_the_proportional_offset_leaves_that_offset() -> None:
    """The method's known limit (docs/blocks/pid.md): with a band of 5 % the error the
    P action alone leaves, 50 - y = y/2 (y = 33.3 %), never enters it, and nothing
    integrates it away."""
    assert _step_response(5.0)[-1] == pytest.approx(100.0 / 3.0, abs=1e-6)


def test_the_compiled_kernels_refuse_the_band_and_the_blocks_run_it() -> None:
    pid = PID(kp=2.0, ti=4.0, ts=0.1, i_band=5.0)
    assert pid.fast_path_blockers() == ["i_band"]
    res = closed_loop(pid, PTn(k=1.0, t=(5.0,), ts=0.1), sp=np.full(10, 1.0))
    assert res.path == "blocks"


def test_a_negative_band_is_refused_and_the_old_configuration_stays() -> None:
    pid = PID(kp=2.0, ti=4.0, i_band=3.0)
    with pytest.raises(ParameterError) as err:
        pid.configure(i_band=-1.0)
    assert err.value.code == ErrorCode.BAD_PARAMETER
    assert pid.config.i_band == 3.0


def test_the_float32_block_follows_the_float64_one() -> None:
    a = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, i_band=5.0)
    b = PID(kp=2.0, ti=1.0, ts=0.1, u_min=-100.0, u_max=100.0, i_band=5.0, precision="float32")
    for pv in (0.0, 0.0, 7.0, 7.0, 8.0, -10.0, -10.0, 9.0, 9.5, 9.9):
        assert b(10.0, pv) == pytest.approx(a(10.0, pv), rel=1e-6, abs=1e-5)


@pytest.mark.slow
def test_the_exported_fb_equals_the_float32_block_with_a_band() -> None:
    """Bit for bit over a closed-loop day (setpoint steps into and out of the band)."""
    pytest.importorskip("blark")
    from ctrlblocks import plc
    from tests.plc.st_interpreter import Interpreter
    from tests.plc.traces import pid_trace, replay, ulps

    block, trace = pid_trace(3000, 11, i_band=4.0)
    fb = Interpreter(plc.export(block, "codesys")).instance("CB_PID")
    got = replay(fb, trace, "MV", "LIMITS_ACTIVE", None)
    assert max(ulps(g[0], ref[0]) for g, ref in zip(got, trace.outputs, strict=True)) == 0
