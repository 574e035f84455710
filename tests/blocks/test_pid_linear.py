"""PID linear behaviour: equal to independently discretised continuous controllers.

Reference: python-control ``sample_system`` of the P, I and D parts (each
with the method of the block: forward = 'euler', backward = 'backward_diff',
tustin = 'tustin'), simulated with ``forced_response`` and summed.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from ctrlblocks import PID

H = 0.05
N_STEPS = 200
CT_METHOD = {"forward": "euler", "backward": "backward_diff", "tustin": "tustin"}

# (form, kp, ti, td) with n = 5; ISA equivalents computed by hand below
FORMS = {
    "isa": (2.0, 1.5, 0.5),
    "parallel": (2.0, 0.75, 1.0),  # ki = 1/0.75, kd = 1.0  ->  K=2, Ti=1.5, Td=0.5
    "series": (2.0, 1.5, 0.5),  # (2.5): K = 2*2/1.5, Ti = 2, Td = 0.375
}
ISA = {
    "isa": (2.0, 1.5, 0.5),
    "parallel": (2.0, 1.5, 0.5),
    "series": (2.0 * 2.0 / 1.5, 2.0, 1.5 * 0.5 / 2.0),
}
NF = 5.0


def _sequence(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, N_STEPS)
    x[0] = 0.0  # the block's first sample initialises its memories
    return x


def _reference(
    form: str, imeth: str, dmeth: str, r: np.ndarray, y: np.ndarray, b: float, c: float
) -> np.ndarray:
    k, ti, td = ISA[form]
    tf = td / NF
    t = np.arange(len(r)) * H
    parts = [
        (control.tf([k], [1]), b * r - y),
        (control.sample_system(control.tf([k / ti], [1, 0]), H, method=CT_METHOD[imeth]), r - y),
        (
            control.sample_system(control.tf([k * td, 0], [tf, 1]), H, method=CT_METHOD[dmeth]),
            c * r - y,
        ),
    ]
    total = np.zeros(len(r))
    for sys, u in parts:
        if sys.isctime():  # the static gain
            total += float(sys.num[0][0][0] / sys.den[0][0][0]) * u
        else:
            total += control.forced_response(sys, T=t, U=u).outputs
    return total


def _run(pid: PID, r: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.array([pid(float(ri), float(yi)) for ri, yi in zip(r, y, strict=True)])


@pytest.mark.parametrize(
    ("form", "imeth", "dmeth"),
    [(f, i, d) for f in FORMS for i in CT_METHOD for d in CT_METHOD],
)
def test_response_to_pv_equals_the_discretised_continuous_pid(
    form: str, imeth: str, dmeth: str
) -> None:
    kp, ti, td = FORMS[form]
    pid = PID(
        kp=kp,
        ti=ti,
        td=td,
        n=NF,
        ts=H,
        u_min=-1e9,
        u_max=1e9,
        form=form,
        integral_method=imeth,
        derivative_method=dmeth,
    )
    y = _sequence(1)
    r = np.zeros_like(y)
    got = _run(pid, r, y)
    want = _reference(form, imeth, dmeth, r, y, 1.0, 0.0)
    assert np.max(np.abs(want)) > 1.0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@pytest.mark.parametrize(("b", "c"), [(1.0, 0.0), (0.5, 0.0), (0.0, 1.0), (0.3, 0.7)])
@pytest.mark.parametrize("dmeth", list(CT_METHOD))
def test_response_to_sp_follows_the_weights_b_and_c(b: float, c: float, dmeth: str) -> None:
    kp, ti, td = FORMS["isa"]
    pid = PID(
        kp=kp,
        ti=ti,
        td=td,
        n=NF,
        b=b,
        c=c,
        ts=H,
        u_min=-1e9,
        u_max=1e9,
        integral_method="tustin",
        derivative_method=dmeth,
    )
    r = _sequence(2)
    y = 0.5 * _sequence(3)
    got = _run(pid, r, y)
    want = _reference("isa", "tustin", dmeth, r, y, b, c)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_first_sample_p_term_is_kp_times_b_r_minus_y() -> None:
    pid = PID(kp=2.0, ti=1.0, b=0.4, ts=0.1, u_min=-100, u_max=100)
    assert pid(5.0, 1.0) == pytest.approx(2.0 * (0.4 * 5.0 - 1.0), abs=1e-12)
    assert pid.p == pytest.approx(2.0, abs=1e-12)


@pytest.mark.parametrize("dmeth", list(CT_METHOD))
def test_forward_integral_equals_astrom_listing_6_3_recursions(dmeth: str) -> None:
    """Åström 1987, (6.4)-(6.6), coded by hand: u = b k r - (k + b_i) y + I + x.

    With ``D[k] = x[k] - b_i y[k]`` (6.3) the state is ``x = a_i D[k-1] + b_i y[k-1]``
    and ``x[k+1] = a_i x[k] + b_i (1 - a_i) y[k]`` (the report prints ``-b_i`` in
    (6.2) and ``-b_i (1 + a_i)`` in (6.4), a sign slip: with those signs (6.3)
    does not follow from (2.13)).
    """
    k, ti, td, n, b, h = 2.0, 1.5, 0.5, 5.0, 0.6, H
    tf = td / n
    a_i, b_i = {
        "forward": (1 - h * n / td, k * n),  # (2.10)
        "backward": (td / (td + n * h), k * td * n / (td + n * h)),  # (2.11)
        "tustin": (
            (2 * td - h * n) / (2 * td + h * n),
            2 * k * n * td / (2 * td + h * n),
        ),  # (2.12)
    }[dmeth]
    assert tf > h / 2
    pid = PID(
        kp=k,
        ti=ti,
        td=td,
        n=n,
        b=b,
        ts=h,
        u_min=-1e9,
        u_max=1e9,
        integral_method="forward",
        derivative_method=dmeth,
    )
    r, y = _sequence(4), _sequence(5)
    i_state = x = 0.0  # rest: D[-1] = 0, y[-1] = y[0] = 0
    for rk, yk in zip(r, y, strict=True):
        u = b * k * rk - (k + b_i) * yk + i_state + x  # (6.5) ComputeOutput
        assert pid(float(rk), float(yk)) == pytest.approx(u, abs=1e-9)
        i_state += k * h / ti * (rk - yk)  # (6.6) UpdateState
        x = a_i * x + b_i * (1 - a_i) * yk
