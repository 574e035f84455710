"""Identification from step responses: two-point methods, least squares, CSV reading."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize, signal

from ctrlblocks.tuning import (
    FOPDT,
    SOPDT,
    DataFileError,
    Integrating,
    fit_fopdt,
    fit_integrating,
    fit_sopdt,
    read_step_csv,
    sundaresan_krishnaswamy,
    two_point,
)

# Nowak et al. 2018, (10a) and (10b): gain and lag time constants of the "true" processes.
K1 = (0.56, (9.5, 4.2))
K2 = (0.73, (7.3, 2.2, 1.4))


def exact_lag_step(k: float, taus: tuple[float, ...], t: np.ndarray) -> np.ndarray:
    """Unit step response of k/prod(tau_i s + 1) with distinct tau_i (partial fractions)."""
    y = np.ones_like(t)
    for i, ti in enumerate(taus):
        coef = ti ** (len(taus) - 1) / math.prod(ti - tj for j, tj in enumerate(taus) if j != i)
        y -= coef * np.exp(-t / ti)
    return k * y


def scipy_crossing(k: float, taus: tuple[float, ...], frac: float) -> float:
    """Time at which the step response reaches frac*k, by scipy.signal.step and brentq."""
    den = np.array([1.0])
    for tau in taus:
        den = np.polymul(den, [tau, 1.0])
    sys = signal.lti([k], den)

    def f(tt: float) -> float:
        return float(signal.step(sys, T=np.array([0.0, tt]))[1][-1]) - frac * k

    return optimize.brentq(f, 1e-6, 200.0, xtol=1e-13)


def lag_record(k, taus, *, t_step=5.0, dt=0.05, t_end=300.0, u0=2.0, du=1.0, y0=1.0):
    t = np.arange(0.0, t_end + dt / 2, dt)
    u = np.where(t >= t_step - 1e-12, u0 + du, u0)
    y = y0 + du * np.where(t >= t_step, exact_lag_step(k, taus, np.maximum(t - t_step, 0.0)), 0.0)
    return t, u, y


@pytest.mark.parametrize("process", [K1, K2], ids=["10a", "10b"])
def test_two_point_equals_marlin_formula_on_exact_crossing_times(process):
    k, taus = process
    t28, t63 = scipy_crossing(k, taus, 0.283), scipy_crossing(k, taus, 0.632)
    m = two_point(*lag_record(k, taus))
    assert m.time_constant == pytest.approx(1.5 * (t63 - t28), abs=1e-6)
    assert m.dead_time == pytest.approx(t63 - 1.5 * (t63 - t28), abs=1e-6)
    assert m.gain == pytest.approx(k, abs=1e-9)


@pytest.mark.parametrize("process", [K1, K2], ids=["10a", "10b"])
def test_sundaresan_krishnaswamy_equals_formula_on_exact_crossing_times(process):
    k, taus = process
    t1, t2 = scipy_crossing(k, taus, 0.353), scipy_crossing(k, taus, 0.853)
    m = sundaresan_krishnaswamy(*lag_record(k, taus, du=-0.5))
    assert m.time_constant == pytest.approx(0.67 * (t2 - t1), abs=1e-6)
    assert m.dead_time == pytest.approx(1.3 * t1 - 0.29 * t2, abs=1e-6)
    assert m.gain == pytest.approx(k, abs=1e-9)


def test_two_point_on_exact_10a_and_10b_is_close_to_the_papers_fopdt():
    # The paper's FOPDT models (11, 3.3) and (8.3, 3) came from the real setup;
    # on the exact models the two-point method gives 11.34/3.06 and 8.21/3.13.
    m1 = two_point(*lag_record(*K1))
    m2 = two_point(*lag_record(*K2))
    assert (round(m1.time_constant, 2), round(m1.dead_time, 2)) == (11.34, 3.06)
    assert (round(m2.time_constant, 2), round(m2.dead_time, 2)) == (8.21, 3.13)


def fopdt_record(seed, *, k=2.0, T=15.0, L=4.2, du=-0.8, noise=0.01, dt=0.5, t_end=150.0):
    """Noisy FOPDT bump test: baseline y0 = 3, MV 1.0 -> 1.0 + du at t = 17.5 s."""
    t = np.arange(0.0, t_end + dt / 2, dt)
    u = np.where(t >= 17.5, 1.0 + du, 1.0)
    y = FOPDT(k, T, L, u0=1.0, y0=3.0).response(t, u)
    y += np.random.default_rng(seed).normal(0.0, noise * abs(k * du), len(t))
    return t, u, y


def test_fopdt_response_is_the_analytic_delayed_exponential():
    t = np.linspace(0.0, 60.0, 241)
    u = np.where(t >= 10.0, 1.5, 0.5)
    y = FOPDT(2.0, 8.0, 3.3, u0=0.5, y0=1.0).response(t, u)
    s = t - 10.0 - 3.3
    expected = 1.0 + 2.0 * np.where(s > 0, 1.0 - np.exp(-np.maximum(s, 0) / 8.0), 0.0)
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-12)


def test_lsq_fopdt_recovers_exact_model_without_noise():
    m = fit_fopdt(*fopdt_record(0, noise=0.0))
    assert m.gain == pytest.approx(2.0, rel=1e-6)
    assert m.time_constant == pytest.approx(15.0, rel=1e-6)
    assert m.dead_time == pytest.approx(4.2, rel=1e-6)
    assert m.y0 == pytest.approx(3.0, abs=1e-6)
    assert m.fit < 1e-6
    assert m.warnings == []


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_lsq_fopdt_recovers_model_from_record_with_1pct_noise(seed):
    m = fit_fopdt(*fopdt_record(seed))
    assert m.gain == pytest.approx(2.0, rel=0.03)
    assert m.time_constant == pytest.approx(15.0, rel=0.05)
    assert m.dead_time == pytest.approx(4.2, rel=0.05)
    assert 0.003 < m.fit < 0.02  # ~ noise/step range


def sopdt_record(seed, *, noise=0.01, dt=0.05):
    """Noisy SOPDT bump test of (10a) with 1.5 s dead time, step up at t = 6 s."""
    t = np.arange(0.0, 120.0 + dt / 2, dt)
    u = np.where(t >= 6.0, 45.0, 40.0)
    y = SOPDT(0.56, 9.5, 1.5, 4.2, u0=40.0, y0=20.0).response(t, u)
    return t, u, y + np.random.default_rng(seed).normal(0.0, noise * 0.56 * 5.0, len(t))


def test_sopdt_response_equals_scipy_step_response():
    t = np.linspace(0.0, 80.0, 401)
    u = np.where(t >= 0.2, 1.0, 0.0)
    for t2 in (4.2, 9.5 * (1 - 1e-10)):  # distinct and (numerically) equal time constants
        y = SOPDT(1.0, 9.5, 0.0, t2).response(t, u)
        sys = signal.lti([1.0], np.polymul([9.5, 1.0], [t2, 1.0]))
        after = t >= 0.2
        ref = signal.step(sys, T=t[after] - 0.2)[1]
        np.testing.assert_allclose(y[after], ref, atol=1e-9)


def test_lsq_sopdt_recovers_exact_model_without_noise():
    m = fit_sopdt(*sopdt_record(0, noise=0.0))
    assert (m.gain, m.time_constant, m.time_constant_2, m.dead_time) == pytest.approx(
        (0.56, 9.5, 4.2, 1.5), rel=1e-5
    )


def test_lsq_sopdt_recovers_model_from_records_with_1pct_noise():
    # 20 noise seeds, 2400 samples each.  Gain and T1 are always within
    # 3 %/5 %.  T2 and the dead time trade off against each other (half a
    # small lag looks like dead time: the half rule), so they scatter more
    # (standard deviation 2.2 % and 2.8 % here; 5.5 % and 6.9 % with 600
    # samples): at least 90 % of the seeds within 5 %, none beyond 10 %.
    # Their half-rule sum L + T2/2 is well determined (within 3 %).  The fit
    # is never worse than the true parameters (it finds the optimum).
    err = []
    for seed in range(1, 21):
        t, u, y = sopdt_record(seed)
        m = fit_sopdt(t, u, y)
        true = SOPDT(0.56, 9.5, 1.5, 4.2, u0=40.0, y0=20.0)
        assert np.sum((y - m.response(t, u)) ** 2) <= np.sum((y - true.response(t, u)) ** 2)
        err.append(
            [
                m.gain / 0.56,
                m.time_constant / 9.5,
                m.time_constant_2 / 4.2,
                m.dead_time / 1.5,
                (m.dead_time + m.time_constant_2 / 2) / (1.5 + 2.1),  # half-rule delay
            ]
        )
    err = np.abs(np.array(err) - 1.0)
    assert np.all(err[:, 0] < 0.03) and np.all(err[:, 1] < 0.05)
    assert np.mean(err[:, 2] < 0.05) >= 0.9 and np.mean(err[:, 3] < 0.05) >= 0.9
    assert np.all(err[:, 2:4] < 0.10)
    assert np.all(err[:, 4] < 0.03)


def test_lsq_handles_any_mv_shape_a_doublet():
    t = np.arange(0.0, 200.0, 0.5)
    u = np.where((t >= 10) & (t < 60), 3.0, 1.0) + np.where(t >= 120, -1.0, 0.0)
    y = FOPDT(-1.2, 7.0, 2.3, u0=1.0, y0=50.0).response(t, u)
    m = fit_fopdt(t, u, y)
    assert (m.gain, m.time_constant, m.dead_time) == pytest.approx((-1.2, 7.0, 2.3), rel=1e-6)


def integrating_record(noise_std):
    t = np.arange(0.0, 100.0, 0.5)
    u = np.where(t >= 20.0, 0.8, 0.5)
    true = Integrating(0.05, 3.0, u0=0.45, y0=10.0, t0=0.0)  # drifts slowly before the step
    return t, u, true.response(t, u) + np.random.default_rng(7).normal(0.0, noise_std, len(t))


def test_integrating_fit_recovers_exact_model_without_noise():
    m = fit_integrating(*integrating_record(0.0))
    assert (m.gain, m.dead_time, m.u0, m.y0) == pytest.approx((0.05, 3.0, 0.45, 10.0), rel=1e-9)


def test_integrating_fit_with_1pct_noise_recovers_gain_and_balancing_mv():
    # PV change over the record ~1.2; noise 1 % of it.  The dead time of a ramp
    # is found from a kink and is the least certain parameter: over 12 seeds
    # its estimate has a standard deviation of 0.25 s, so 3 sigma is allowed.
    m = fit_integrating(*integrating_record(0.012))
    assert m.gain == pytest.approx(0.05, rel=0.03)
    assert m.u0 == pytest.approx(0.45, abs=0.01)
    assert m.dead_time == pytest.approx(3.0, abs=0.75)


def test_short_record_warns_that_steady_state_is_not_reached():
    t, u, y = fopdt_record(0, noise=0.0, t_end=45.0)  # step at 17.5 s, needs 4.2 + 60 s
    m = fit_fopdt(t, u, y)
    assert any("to settle" in w for w in m.warnings)
    assert not fit_fopdt(*fopdt_record(0, noise=0.0)).warnings


def test_two_point_warns_on_noisy_record():
    m = two_point(*fopdt_record(1, noise=0.03))
    assert any("noisy record" in w for w in m.warnings)


def test_integrating_model_on_a_self_regulating_record_reports_poor_fit():
    m = fit_integrating(*fopdt_record(1))
    assert m.fit > 0.05
    assert any("poor fit" in w for w in m.warnings)


def test_record_without_mv_step_is_refused():
    t = np.arange(20.0)
    with pytest.raises(ValueError, match="never changes"):
        fit_fopdt(t, np.ones(20), t)


# --------------------------------------------------------------------------
# CSV reader
# --------------------------------------------------------------------------


def write(tmp_path, text, name="bump.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def good_rows(n=12, start=2):
    return "".join(f"{i * 0.5},{1.0 if i < 3 else 2.0},{0.1 * i}\n" for i in range(n))


def test_read_step_csv_reads_named_columns_in_any_order_with_semicolons(tmp_path):
    p = write(tmp_path, "# bump test\npv;extra;time;mv\n" + "".join(
        f"{0.1 * i};x;{i * 0.5};{1.0 if i < 3 else 2.0}\n" for i in range(12)
    ))  # fmt: skip
    d = read_step_csv(p, time="time", u="mv", y="pv")
    assert d.t[-1] == 5.5 and d.u[2] == 1.0 and d.u[3] == 2.0 and d.y[11] == pytest.approx(1.1)


BAD_FILES = [
    # (content, line, column, text in the message)
    ("t,u\n" + good_rows(), 1, "y", "no such column"),
    ("t,u,y\n" + good_rows(5) + "2.5,2.0,abc\n" + good_rows(), 7, "y", "'abc' is not a number"),
    ("t,u,y\n" + good_rows(5) + "2.5,,0.3\n", 7, "u", "empty cell"),
    ("t,u,y\n" + good_rows(4) + "1.0,2.0,0.5\n" + good_rows(), 6, "t", "not after"),
    ("t,u,y\n" + good_rows(5), 6, None, "only 5 data row"),
    ("t,u,y\n" + "".join(f"{i},1.0,{i}\n" for i in range(12)), None, "u", "never changes"),
    ("t,u,y\n" + good_rows(5) + "2.5,2.0,nan\n" + good_rows(), 7, "y", "not a finite number"),
]


@pytest.mark.parametrize(("content", "line", "column", "text"), BAD_FILES)
def test_bad_csv_gives_one_error_naming_file_line_and_column(tmp_path, content, line, column, text):
    p = write(tmp_path, content)
    with pytest.raises(DataFileError) as info:
        read_step_csv(p, time="t", u="u", y="y")
    err = info.value
    assert (err.path, err.line, err.column) == (str(p), line, column)
    assert text in str(err)
    assert str(err).startswith(str(p))
    if line is not None:
        assert f"line {line}" in str(err)
    if column is not None:
        assert f"column '{column}'" in str(err)


def test_missing_file_is_a_data_file_error(tmp_path):
    with pytest.raises(DataFileError, match="cannot read"):
        read_step_csv(tmp_path / "nope.csv")


def test_sample_bump_test_file_identifies_process_10b():
    from pathlib import Path

    d = read_step_csv(
        Path(__file__).parent / "data" / "bump_k2.csv", time="time_s", u="p_supply_bar", y="p3_bar"
    )
    m = fit_fopdt(d.t, d.u, d.y)
    assert m.gain == pytest.approx(0.73, rel=0.01)
    s = fit_sopdt(d.t, d.u, d.y)
    assert s.fit < m.fit  # the third-order process is better described by SOPDT


def test_lsq_with_a_noisy_measured_mv_is_fast_and_accurate():
    t = np.arange(0.0, 600.0, 0.2)  # 3000 samples, the MV "changes" at every one
    rng = np.random.default_rng(3)
    u = np.where(t >= 50.0, 3.0, 1.0)
    y = FOPDT(2.0, 15.0, 4.2, u0=1.0, y0=3.0).response(t, u) + rng.normal(0.0, 0.04, len(t))
    m = fit_fopdt(t, u + rng.normal(0.0, 0.01, len(t)), y)
    assert (m.gain, m.time_constant, m.dead_time) == pytest.approx((2.0, 15.0, 4.2), rel=0.03)
    assert m.warnings == []
