"""An independent closed form of the ADRC's exact discretisation, for the tests.

The package computes the gains of ``discretisation="exact"`` with one function
the PLC can also run (``ctrlblocks.blocks.adrc.exact_coefficients``: the
polynomials in ``d = 1 - exp(-omega h)`` spelled out for n = 1, 2, 3).  This is
the same design computed another way -- numpy, ``expm1``, the constant vectors
of the scaled chain derived by matrix algebra for any order -- so that the two
check each other to 1e-13 over ``omega h`` from 1e-9 to 40 (where scipy's
``expm`` with Ackermann's formula cancels for a tiny ``omega h``).
"""

from __future__ import annotations

import functools
import math

import numpy as np


def _pow(x: float, k: int) -> float:
    try:
        return x**k
    except OverflowError:
        return math.inf if x > 0.0 or k % 2 == 0 else -math.inf


def exact_coefficients(
    n: int, b0: float, omega_c: float, omega_o: float, ts: float
) -> tuple[tuple[float, ...], tuple[float, float, float]]:
    """ZOH matrices, current-observer gain and controller gains (Ackermann), in closed form.

    Returns ``(f01, f02, f03, f12, f13, f23, g0, g1, g2, c0, c1, c2, c3)`` in
    the 4-state layout and ``(kp, kd1, kd2)``.

    The chain of ``m = n + 1`` integrators (Y, its derivatives, h) has
    ``Phi[i][j] = ts^(j-i)/(j-i)!``.  In the scaled state ``x_i ts^i`` it becomes
    the constant ``exp(N)`` (N the shift matrix), so Ackermann's formula
    ``Lp = p(Phi) O^-1 e_last`` with ``p(z) = (z - z_o)^m = ((z - 1) + d)^m``,
    ``d = 1 - exp(-omega_o ts)``, is a sum of constant vectors times ``d^k``
    (:func:`_chain_constants`); unscaling multiplies entry i by ``ts^-i`` and
    only terms with ``k > i`` occur, written ``(d/ts)^i d^(k-i)``.  So the gains are
    accurate for every ``omega_o ts`` (no cancellation when it is tiny, no
    singular matrix at ``ts = 1e-300``).  Example, n = 1: ``Lc = (1 - z_o^2,
    (1 - z_o)^2/ts)``.  The controller gains are placed likewise on the n-chain
    (all poles at ``exp(-omega_c ts)``).
    """
    m = n + 1
    idx = {1: [0, 3], 2: [0, 1, 3], 3: [0, 1, 2, 3]}[n]
    h = ts
    phi = np.eye(4)
    gam = np.zeros(4)
    for a in range(m):
        for b in range(a + 1, m):
            phi[idx[a], idx[b]] = _pow(h, b - a) / math.factorial(b - a)
        if a < n:
            gam[idx[a]] = b0 * _pow(h, n - a) / math.factorial(n - a)
    obs_terms, ctl_terms = _chain_constants(n)
    lc_r = _scaled_gain(obs_terms, m, omega_o, h, observer=True)
    kk = _scaled_gain(ctl_terms, n, omega_c, h, observer=False) + [0.0] * (3 - n)
    lc = np.zeros(4)
    lc[idx] = lc_r
    coef = (
        float(phi[0, 1]),
        float(phi[0, 2]),
        float(phi[0, 3]),
        float(phi[1, 2]),
        float(phi[1, 3]),
        float(phi[2, 3]),
        float(gam[0]),
        float(gam[1]),
        float(gam[2]),
        *(float(v) for v in lc),
    )
    return coef, (kk[0], kk[1], kk[2])


def _scaled_gain(
    terms: list[np.ndarray], size: int, omega: float, h: float, *, observer: bool
) -> list[float]:
    """Gain entries from the constant vectors ``terms[k]`` (coefficient of ``d^k``).

    Observer entry i: ``sum_k terms[k][i] (d/h)^i d^(k-i)`` (``k > i``).
    Controller entry i: ``sum_k terms[k][i] (d/h)^(size-i) d^(k-size+i)``
    (``k >= size - i``).  ``d = 1 - exp(-omega h)`` by ``expm1``; ``d/h`` tends to
    ``omega`` as ``omega h -> 0``.
    """
    a = omega * h
    d = -math.expm1(-a)
    q = omega * (d / a) if a > 1e-300 else omega  # d/h without dividing by a subnormal h
    out = []
    for i in range(size):
        p = i if observer else size - i
        acc = 0.0
        for k in range(1, size + 1):
            c = float(terms[k][i])
            if c != 0.0 and k >= p:
                acc += c * _pow(q, p) * _pow(d, k - p)
        out.append(acc)
    return out


@functools.cache
def _chain_constants(n: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Constant vectors of the scaled chain for :func:`_exact_coefficients`.

    Observer (m = n + 1 states): ``C(m, k) exp(-N) W^(m-k) O^-1 e_last``,
    ``W = exp(N) - I``; controller (n states, input on the last): ``C(n, k)
    e_last^T Ctrb^-1 W^(n-k)`` with ``Ctrb = [g, exp(N) g, ...]``, ``g_i =
    1/(n-i)!``.  Index k = 0..size (entry 0 unused).  Exact small rational
    matrices, computed once per order.
    """

    def expn(size: int, sign: float) -> np.ndarray:
        e = np.zeros((size, size))
        for i in range(size):
            for j in range(i, size):
                e[i, j] = sign ** (j - i) / math.factorial(j - i)
        return e

    m = n + 1
    phi, pinv = expn(m, 1.0), expn(m, -1.0)
    w = phi - np.eye(m)
    obs = np.array([np.linalg.matrix_power(phi, k)[0] for k in range(m)])
    v = np.linalg.solve(obs, np.eye(m)[-1])
    obs_terms = [np.zeros(m)] + [
        math.comb(m, k) * (pinv @ np.linalg.matrix_power(w, m - k) @ v) for k in range(1, m + 1)
    ]
    phic = phi[:n, :n]
    wc = phic - np.eye(n)
    g = np.array([1.0 / math.factorial(n - i) for i in range(n)])
    ctrb = np.column_stack([np.linalg.matrix_power(phic, k) @ g for k in range(n)])
    r0 = np.linalg.solve(ctrb.T, np.eye(n)[-1])
    ctl_terms = [np.zeros(n)] + [
        math.comb(n, k) * (r0 @ np.linalg.matrix_power(wc, n - k)) for k in range(1, n + 1)
    ]
    return obs_terms, ctl_terms
