"""JumpAndRate (Åström 1987, Figs. 5.1/5.2, system ``jar``): exact discretisation, Fig. 5.2."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrlblocks import ErrorCode, JumpAndRate, ParameterError
from ctrlblocks.blocks.jumprate import jar_state_update

E4 = math.exp(-4.0)


def _fig52_input(t: float) -> float:
    """Input of Åström 1987, macro fig52: 4 until t1 = 7, 1 until 15, 3 until 18, then 2."""
    return 4.0 if t < 7 else 1.0 if t < 15 else 3.0 if t < 18 else 2.0


def _run_fig52(h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = round(20.0 / h)
    t = np.arange(n + 1) * h
    jar = JumpAndRate(jlow=-0.5, jhigh=1.0, rlow=-0.5, rhigh=1.0, ts=h)
    u = np.array([_fig52_input(round(tk, 9)) for tk in t])
    y = np.array([jar(float(uk)) for uk in u])
    return t, u, y


def _fig52_by_hand() -> dict[float, float]:
    """Output of Fig. 5.2 at chosen instants, from the piecewise solution of system ``jar``.

    0..7 (u=4): jump +1, ramp x = t until e = u - x = 1 (t = 3), then e = exp(-(t-3)),
    so x(7) = 4 - e^-4 and y = u from t = 3.
    7..15 (u=1): e = -3 + e^-4 < -0.5: jump -0.5, ramp -0.5/s until x = 1.5 at
    tB = 7 + (x7 - 1.5)/0.5 = 11.963; then x = 1 + 0.5 exp(-(t - tB)), y = 1.
    15..18 (u=3): e = 3 - x15 > 1: jump +1, ramp +1/s until x = 2 at tC = 15 + (2 - x15),
    then x = 3 - exp(-(t - tC)), y = 3.
    18..20 (u=2): e = 2 - x18 < -0.5: jump -0.5, ramp until x = 2.5 at tD, then y = 2.
    """
    x7 = 4.0 - E4
    t_b = 7.0 + (x7 - 1.5) / 0.5
    x15 = 1.0 + 0.5 * math.exp(-(15.0 - t_b))
    t_c = 15.0 + (2.0 - x15)
    x18 = 3.0 - math.exp(-(18.0 - t_c))
    t_d = 18.0 + (x18 - 2.5) / 0.5
    assert t_b == pytest.approx(11.963369, abs=1e-6)
    assert x15 == pytest.approx(1.023998, abs=1e-6)
    assert x18 == pytest.approx(2.867874, abs=1e-6)
    assert t_d == pytest.approx(18.735748, abs=1e-6)
    return {
        0.0: 1.0,  # jump +1 at once
        1.5: 2.5,  # ramp +1/s from the jump
        3.0: 4.0,  # at the input
        6.5: 4.0,
        7.0: x7 - 0.5,  # 3.4817: jump -0.5
        9.0: x7 - 0.5 - 1.0,  # ramp -0.5/s for 2 s
        11.5: x7 - 0.5 - 0.5 * 4.5,
        13.0: 1.0,
        15.0: x15 + 1.0,  # 2.024: jump +1
        15.5: x15 + 1.5,
        17.0: 3.0,
        18.0: x18 - 0.5,  # 2.368: jump -0.5
        18.5: x18 - 0.75,
        19.5: 2.0,
        20.0: 2.0,
    }


@pytest.mark.parametrize("h", [0.01, 0.1, 0.5])
def test_fig_5_2_experiment_matches_the_piecewise_solution(h: float) -> None:
    t, _, y = _run_fig52(h)
    for when, expected in _fig52_by_hand().items():
        k = round(when / h)
        assert t[k] == pytest.approx(when)
        assert y[k] == pytest.approx(expected, abs=1e-12), when


def test_fig_5_2_output_rates_and_jumps_respect_the_limits() -> None:
    _, u, y = _run_fig52(0.01)
    steps = np.diff(y)
    input_changes = np.flatnonzero(np.diff(u)) + 1
    between = np.setdiff1d(np.arange(1, len(y)), input_changes) - 1
    # away from input changes the output moves at most rhigh*h up and |rlow|*h down
    assert steps[between].max() <= 1.0 * 0.01 + 1e-12
    assert steps[between].min() >= -0.5 * 0.01 - 1e-12
    # at the input changes the output jumps (Fig. 5.2): -0.5 - e^-4 at t = 7, ...
    assert steps[input_changes - 1] == pytest.approx([-0.5 - E4, 1.023998, -0.632126], abs=1e-6)


def _reference_state(x0: float, u: float, h: float, rlow: float, rhigh: float) -> float:
    sol = solve_ivp(
        lambda _t, x: [min(max(u - x[0], rlow), rhigh)],
        (0.0, h),
        [x0],
        method="RK45",
        rtol=1e-11,
        atol=1e-13,
        max_step=h / 50,
    )
    return float(sol.y[0, -1])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_exact_update_equals_a_fine_step_ode_solution(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rlow, rhigh = -rng.uniform(0.1, 2.0), rng.uniform(0.1, 2.0)
    h = float(rng.uniform(0.2, 1.5))
    x = 0.0
    for _ in range(25):
        u = float(rng.normal(scale=3.0))
        x_exact = jar_state_update(x, u, h, rlow, rhigh)
        assert x_exact == pytest.approx(_reference_state(x, u, h, rlow, rhigh), abs=1e-8)
        x = x_exact


def test_exact_update_is_independent_of_the_sample_time() -> None:
    _, _, y_fine = _run_fig52(0.01)
    _, _, y_coarse = _run_fig52(0.5)
    assert np.max(np.abs(y_fine[::50] - y_coarse)) < 1e-12


@pytest.mark.parametrize(
    ("x", "u", "h", "expected"),
    [
        (0.0, 4.0, 1.0, 1.0),  # ramp at rhigh = 1 the whole sample
        (0.0, 4.0, 3.5, 4.0 - math.exp(-0.5)),  # 3 s ramp, then 0.5 s exponential
        (4.0, 0.0, 2.0, 3.0),  # ramp at rlow = -0.5
        (0.0, 0.5, 1.0, 0.5 - 0.5 * math.exp(-1.0)),  # linear region: time constant 1 s
        (2.0, 2.0, 1.0, 2.0),  # at rest
    ],
)
def test_state_update_by_hand(x: float, u: float, h: float, expected: float) -> None:
    assert jar_state_update(x, u, h, -0.5, 1.0) == pytest.approx(expected, abs=1e-15)


def test_zero_rate_freezes_the_state_in_that_direction() -> None:
    assert jar_state_update(1.0, 5.0, 1.0, -1.0, 0.0) == 1.0
    assert jar_state_update(1.0, -5.0, 1.0, 0.0, 1.0) == 1.0
    jar = JumpAndRate(jlow=-1.0, jhigh=0.5, rlow=-1.0, rhigh=0.0, ts=0.1)
    assert [jar(3.0) for _ in range(3)] == [0.5, 0.5, 0.5]


def test_infinite_limits_pass_the_input() -> None:
    jar = JumpAndRate(jlow=-math.inf, jhigh=math.inf, rlow=-math.inf, rhigh=math.inf)
    assert [jar(v) for v in (3.0, -2.0, 7.5)] == [3.0, -2.0, 7.5]


def test_flags_tell_which_limit_acted() -> None:
    jar = JumpAndRate(jlow=-0.5, jhigh=1.0, rlow=-0.5, rhigh=2.0, ts=0.1)
    jar(1.5)  # e = 1.5: jump-limited, inside the rate limits
    assert jar.jump_limited and not jar.rate_limited
    jar.preset(0.0)
    jar(3.0)
    assert jar.jump_limited and jar.rate_limited
    jar.preset(0.0)
    jar(0.2)
    assert not jar.jump_limited and not jar.rate_limited and jar.out == 0.2


def test_preset_settles_output_and_state() -> None:
    jar = JumpAndRate(ts=0.1)
    jar.preset(5.0)
    assert jar.x == 5.0 and jar(5.0) == 5.0 and jar.x == 5.0


def test_nan_input_holds_and_recovers() -> None:
    jar = JumpAndRate(ts=0.1)
    y = jar(3.0)
    x = jar.x
    assert jar(math.nan) == y and jar.x == x
    assert jar.error_id == ErrorCode.BAD_INPUT
    assert jar(3.0) == pytest.approx(x + 1.0, abs=1e-15)
    assert jar.error_id == ErrorCode.NO_ERROR


@pytest.mark.parametrize("dt", [0.0, -1.0, math.nan, math.inf])
def test_bad_dt_gives_no_cycle_and_the_previous_output(dt: float) -> None:
    jar = JumpAndRate(ts=0.1)
    y = jar(3.0)
    assert jar(3.0, dt=dt) == y and jar.error_id == ErrorCode.NO_CYCLE


def test_per_call_dt_advances_by_that_time() -> None:
    jar = JumpAndRate(ts=0.1)
    jar(4.0, dt=2.0)
    assert jar.x == pytest.approx(2.0, abs=1e-15)


@pytest.mark.parametrize(
    ("params", "code"),
    [
        ({"jlow": 0.5}, ErrorCode.BAD_LIMITS),  # jump pair must contain 0
        ({"jlow": 2.0, "jhigh": 1.0}, ErrorCode.BAD_LIMITS),
        ({"jhigh": math.nan}, ErrorCode.BAD_LIMITS),
        ({"rhigh": -0.1}, ErrorCode.BAD_RATE),
        ({"rlow": 0.2}, ErrorCode.BAD_RATE),
        ({"rlow": math.nan}, ErrorCode.BAD_RATE),
        ({"rhigh": "fast"}, ErrorCode.BAD_RATE),
        ({"rhigh": True}, ErrorCode.BAD_RATE),
        ({"ts": 0.0}, ErrorCode.NO_CYCLE),
    ],
)
def test_bad_configuration_has_its_code(params: dict, code: ErrorCode) -> None:
    with pytest.raises(ParameterError) as info:
        JumpAndRate(**params)
    assert info.value.code == code
