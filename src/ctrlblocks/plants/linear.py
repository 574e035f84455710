"""Linear process models: transfer function or state space, exact ZOH, input dead time.

A continuous linear time-invariant model

    dx/dt = A x + B u(t - tau),      y = C x                            (1)

driven by a zero-order-hold input (``u(t) = u[k]`` for ``k ts <= t < (k+1) ts``)
is sampled exactly (no approximation) by the ZOH discretisation (Åström and
Wittenmark, *Computer-Controlled Systems*, 3rd ed., section 2.3; the same as
:func:`scipy.signal.cont2discrete` with ``method="zoh"``).

Dead time
---------
Write the dead time as ``tau = d ts + eps`` with a whole number ``d >= 0`` and
``0 <= eps < ts``.  Within one sample the delayed input takes two values: the
older ``u[k-d-1]`` during the first ``eps`` seconds and ``u[k-d]`` during the
remaining ``ts - eps``.  Integrating (1) over the sample gives the exact update
(the modified z-transform of a delayed ZOH system, Åström and Wittenmark,
section 2.3, "Time delay")

    x[k+1] = Phi x[k] + Gamma0 u[k-d] + Gamma1 u[k-d-1]                  (2)

    Phi    = exp(A ts)
    Gamma0 = int_0^(ts-eps) exp(A s) ds B
    Gamma1 = exp(A (ts-eps)) int_0^eps exp(A s) ds B

so a dead time that is **not** a multiple of ``ts`` is still exact for a ZOH
input (rounding it to whole samples is not, and is not done here).  Past inputs
are kept in a ring buffer of ``d + 2`` samples (the "Lagging" block of controltheplant 2024,
``LSim_Lagging``).  With ``eps = 0``, ``Gamma1 = 0`` and ``Gamma0 = Gamma``,
the ordinary ZOH input matrix.

Convenience models (controltheplant 2024, section 1.3, ``/sim`` blocks; Nowak et al. 2018, (10))
--------------------------------------------------------------------------
==========  ===============================================  ==================
class       transfer function                                 source
==========  ===============================================  ==================
``PT1``     ``k / (t s + 1)``                                  controltheplant 2024 LSim_PT1
``PT2``     ``k / ((t1 s + 1)(t2 s + 1))``                     ctrlblocks
``PT2Osc``  ``k / (t^2 s^2 + 2 zeta t s + 1)``                 ctrlblocks
``PTn``     ``k / prod(t_i s + 1)``                            Nowak et al. 2018, (10a)/(10b)
``IT1``     ``k / (s (t s + 1))``                              controltheplant 2024 LSim_IT1
``FOPDT``   ``k e^(-dead_time s) / (t s + 1)``                 Nowak et al. 2018, (10) right
==========  ===============================================  ==================

Every class takes ``dead_time`` [s] (default 0).  Times are in seconds; the
gain ``k`` is in output units per input unit (for ``IT1``: per second).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_finite,
    require_nonnegative,
    require_positive,
)
from .base import Plant

__all__ = [
    "FOPDT",
    "IT1",
    "MAX_DEAD_SAMPLES",
    "PT1",
    "PT2",
    "LinearPlant",
    "PT2Osc",
    "PTn",
    "require_dead_time",
    "split_dead_time",
]

_WHOLE_TOL = 1e-9  # relative tolerance for "tau is a whole number of samples"


MAX_DEAD_SAMPLES = 1_000_000
"""The longest dead time a plant holds, in samples (the buffer of its input history)."""


def require_dead_time(value: Any, ts: float) -> float:
    """``value`` as a dead time [s] >= 0 of at most :data:`MAX_DEAD_SAMPLES` samples of ``ts``.

    Raises :class:`ParameterError` (``BAD_TIME_CONSTANT``) otherwise: a
    finite dead time whose history would not fit in memory (``1e308`` s, or
    a sample time of ``1e-320`` s) is refused when the plant is made, not
    when its buffer is allocated.
    """
    dead_time = require_nonnegative("dead_time", value, ErrorCode.BAD_TIME_CONSTANT)
    if not dead_time / ts <= MAX_DEAD_SAMPLES:
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT,
            "dead_time",
            f"{dead_time!r} s is more than {MAX_DEAD_SAMPLES:,} samples of ts = {ts!r} s",
        )
    return dead_time


def split_dead_time(dead_time: float, ts: float) -> tuple[int, float]:
    """Split ``dead_time`` into whole samples ``d`` and a remainder ``eps`` in ``[0, ts)``.

    A ratio within 1e-9 of a whole number counts as whole (so ``0.3 / 0.1``
    gives ``d = 3, eps = 0`` despite floating-point rounding).

    >>> d, eps = split_dead_time(0.35, 0.1)
    >>> d, round(eps, 12)
    (3, 0.05)
    >>> split_dead_time(0.3, 0.1)
    (3, 0.0)
    """
    r = dead_time / ts
    n = round(r)
    if abs(r - n) <= _WHOLE_TOL * max(1.0, abs(r)):
        return int(n), 0.0
    d = math.floor(r)
    return int(d), dead_time - d * ts


def lti_step(
    x: list[float],
    phi: tuple[tuple[float, ...], ...],
    g0: tuple[float, ...],
    g1: tuple[float, ...],
    u0: float,
    u1: float,
) -> list[float]:
    """One sample of (2): ``Phi x + Gamma0 u0 + Gamma1 u1`` over plain floats."""
    n = len(x)
    out = [0.0] * n
    for i in range(n):
        row = phi[i]
        s = g0[i] * u0 + g1[i] * u1
        for j in range(n):
            s += row[j] * x[j]
        out[i] = s
    return out


def lti_output(x: list[float], c: tuple[float, ...]) -> float:
    """``y = C x`` over plain floats."""
    s = 0.0
    for j in range(len(x)):
        s += c[j] * x[j]
    return s


def _zoh(a: np.ndarray, b: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH ``(Phi, Gamma)`` of ``(A, B)`` over ``h`` seconds (Åström and Wittenmark, 2.3).

    The exponential of the augmented matrix ``[[A, B], [0, 0]] h`` -- the
    computation of ``scipy.signal.cont2discrete(..., method="zoh")``, done
    here with ``scipy.linalg.expm`` so that the plants do not import
    ``scipy.signal`` (over a second of start-up).
    """
    from scipy.linalg import expm

    nx, nu = a.shape[0], b.shape[1]
    # Gamma is linear in B: a B far larger than A (a gain of 1e100 in the input matrix) would
    # set expm's scaling and cost Phi its accuracy (a closed-loop pole off in the 7th digit,
    # at 1e200 not finite), so such a B is divided by a power of two (exact) and Gamma
    # multiplied back; ordinary models (B within 2**10 of A and 1/h) are computed as they were
    with np.errstate(all="ignore"):
        big = float(np.max(np.abs(b))) / max(float(np.max(np.abs(a))), 1.0 / h)
    scale = math.ldexp(1.0, min(1000, round(math.log2(big)))) if 2.0**10 < big < math.inf else 1.0
    em = np.vstack((np.hstack((a, b / scale)), np.zeros((nu, nx + nu))))
    with np.errstate(all="ignore"):  # an overflow is refused below, with the cause
        ms = expm(h * em)[:nx, :]
        ms[:, nx:] *= scale
    if not np.all(np.isfinite(ms)):  # h * A overflows (ts = 1e308), or A grows beyond floats
        raise ParameterError(
            ErrorCode.NO_CYCLE,
            "ts",
            f"{h!r} s is too long for this model: its discrete model over one sample is not finite",
        )
    return ms[:, :nx], ms[:, nx:]


def _as_matrix(name: str, m: Any, shape: tuple[int, int]) -> np.ndarray:
    a = np.atleast_2d(np.asarray(m, dtype=float))
    if a.shape != shape:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER, name, f"must have shape {shape}, got {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise ParameterError(ErrorCode.BAD_PARAMETER, name, "must be finite")
    return a


class LinearPlant(Plant):
    """Linear SISO plant (1), sampled exactly by ZOH (2), with optional input dead time.

    Give either a transfer function (``num``, ``den``: polynomial coefficients
    in descending powers of ``s``, strictly proper: ``len(num) < len(den)``
    after leading zeros are stripped) or a state space (``A``, ``B``, ``C``
    and optionally ``D``, which must be zero).

    Parameters
    ----------
    num, den : sequence of float, optional
        Transfer function ``num(s)/den(s)``.
    ts : float
        Sample time [s], > 0.
    A, B, C, D : array_like, optional
        State space (1); ``A`` is n x n, ``B`` n x 1, ``C`` 1 x n, ``D`` 0.
    dead_time : float
        Input dead time ``tau`` [s], >= 0; any value, exact for a ZOH input.

    Attributes
    ----------
    ts : float
        Sample time [s].
    u : float
        The input applied in the last ``step`` (after ``reset(u0)``: ``u0``).
    phi, gamma0, gamma1, c : numpy.ndarray
        The discrete matrices of (2) and the output row ``C``.
    dead_samples : int
        Whole samples ``d`` of the dead time.
    dead_fraction : float
        Remainder ``eps`` [s] of the dead time, ``0 <= eps < ts``.

    Notes
    -----
    A non-finite input (NaN, inf) is never propagated into the state: the
    previous input is held instead (the plant does not raise on process data).

    Examples
    --------
    >>> p = LinearPlant([2.0], [5.0, 1.0], ts=0.1)      # 2/(5s+1)
    >>> p.reset(1.0)
    >>> round(p.y, 12)
    2.0
    """

    def __init__(
        self,
        num: Sequence[float] | None = None,
        den: Sequence[float] | None = None,
        *,
        ts: float,
        A: Any = None,
        B: Any = None,
        C: Any = None,
        D: Any = None,
        dead_time: float = 0.0,
    ) -> None:
        self.ts = require_positive("ts", ts, ErrorCode.NO_CYCLE)
        self.dead_time = require_dead_time(dead_time, self.ts)
        a, b, c = self._continuous(num, den, A, B, C, D)
        self.a_c, self.b_c, self.c_c = a, b, c
        self._discretise()
        self.reset(0.0)

    # -- construction --------------------------------------------------------

    @staticmethod
    def _continuous(
        num: Any, den: Any, A: Any, B: Any, C: Any, D: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tf_given = num is not None or den is not None
        ss_given = any(m is not None for m in (A, B, C))
        if tf_given == ss_given:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "num/den|A/B/C", "give either (num, den) or (A, B, C)"
            )
        if tf_given:
            if num is None or den is None:
                raise ParameterError(ErrorCode.BAD_PARAMETER, "num/den", "give both num and den")
            n = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
            d = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
            if d.size < 2 or not np.all(np.isfinite(d)) or not np.all(np.isfinite(n)):
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, "den", "must be finite and of degree >= 1"
                )
            if n.size == 0:
                n = np.zeros(1)
            if n.size >= d.size:
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER,
                    "num",
                    "the plant must be strictly proper (deg num < deg den)",
                )
            from scipy import signal  # only here: importing scipy.signal costs ~1-2.5 s

            a, b, c, _ = signal.tf2ss(n, d)
            return np.asarray(a, float), np.asarray(b, float), np.asarray(c, float)
        if A is None or B is None or C is None:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "A/B/C", "give A, B and C")
        a = np.atleast_2d(np.asarray(A, dtype=float))
        nx = a.shape[0]
        a = _as_matrix("A", a, (nx, nx))
        b = _as_matrix("B", np.reshape(np.asarray(B, dtype=float), (nx, 1)), (nx, 1))
        c = _as_matrix("C", np.reshape(np.asarray(C, dtype=float), (1, nx)), (1, nx))
        if D is not None and np.any(np.asarray(D, dtype=float) != 0.0):
            raise ParameterError(
                ErrorCode.BAD_PARAMETER, "D", "the plant must be strictly proper (D = 0)"
            )
        return a, b, c

    def _discretise(self) -> None:
        a, b, c = self.a_c, self.b_c, self.c_c
        nx = a.shape[0]
        d, eps = split_dead_time(self.dead_time, self.ts)
        self.dead_samples, self.dead_fraction = d, eps
        phi, gam = _zoh(a, b, self.ts)
        if eps > 0.0:
            phi_r, gam_r = _zoh(a, b, self.ts - eps)
            gam_e = _zoh(a, b, eps)[1]
            g0 = gam_r
            g1 = phi_r @ gam_e
        else:
            g0, g1 = gam, np.zeros((nx, 1))
        self.phi = np.asarray(phi, float)
        self.gamma0 = np.asarray(g0, float).reshape(nx)
        self.gamma1 = np.asarray(g1, float).reshape(nx)
        self.c = c.reshape(nx).copy()
        # plain-float copies for the per-sample path
        self._phi = tuple(tuple(float(v) for v in row) for row in self.phi)
        self._g0 = tuple(float(v) for v in self.gamma0)
        self._g1 = tuple(float(v) for v in self.gamma1)
        self._c = tuple(float(v) for v in self.c)
        # steady state map x_ss = (I - Phi)^-1 (Gamma0 + Gamma1) u0, None if integrating
        m = np.eye(nx) - self.phi
        self._x_per_u: np.ndarray | None = None
        if np.linalg.cond(m) < 1e12:
            x_per_u = np.linalg.solve(m, self.gamma0 + self.gamma1)
            if np.all(np.isfinite(x_per_u)):  # (ts = 1e-320: Phi = I to the last bit)
                self._x_per_u = x_per_u
        self._buf_len = d + 2

    # -- the contract ----------------------------------------------------------

    @property
    def n_states(self) -> int:
        """Number of continuous states ``n`` (the dead-time buffer not counted)."""
        return len(self._c)

    @property
    def integrating(self) -> bool:
        """True when the model has a pole at ``s = 0`` (no steady state for ``u != 0``)."""
        return self._x_per_u is None

    @property
    def dc_gain(self) -> float:
        """Static gain ``y/u`` in steady state (``inf`` for an integrating plant)."""
        if self._x_per_u is None:
            return math.inf
        return float(self.c @ self._x_per_u)

    @property
    def y(self) -> float:
        """Current output ``y[k] = C x[k]``."""
        return self._y

    @property
    def state(self) -> list[float]:
        """The state vector ``x[k]`` as a list of floats (a copy)."""
        return list(self._x)

    def step(self, u: float) -> float:
        """Apply ``u[k]`` for one sample (ZOH); return ``y[k+1]``.

        A non-finite ``u`` holds the previous input.
        """
        if not math.isfinite(u):
            u = self.u
        u = float(u)
        self.u = u
        buf, n, pos, d = self._buf, self._buf_len, self._pos, self.dead_samples
        buf[pos] = u
        u0 = buf[(pos - d) % n]
        u1 = buf[(pos - d - 1) % n]
        self._pos = (pos + 1) % n
        self._x = lti_step(self._x, self._phi, self._g0, self._g1, u0, u1)
        self._y = lti_output(self._x, self._c)
        return self._y

    def reset(self, u0: float = 0.0) -> None:
        """Steady state for the constant input ``u0``; the dead-time buffer holds ``u0``.

        For an integrating plant the state is zero (and the input ``u0`` is
        held in the buffer), as the :class:`~.base.Plant` contract says.
        """
        u0 = float(u0) if math.isfinite(u0) else 0.0
        self.u = u0
        if self._x_per_u is None:
            self._x = [0.0] * self.n_states
        else:
            self._x = [float(v) * u0 for v in self._x_per_u]
        self._buf = [u0] * self._buf_len
        self._pos = 0
        self._y = lti_output(self._x, self._c)

    def set_state(self, x: Sequence[float]) -> None:
        """Overwrite the state vector ``x`` (length ``n_states``); the buffer is kept."""
        if len(x) != self.n_states:
            raise ValueError(f"state must have {self.n_states} entries, got {len(x)}")
        self._x = [float(v) for v in x]
        self._y = lti_output(self._x, self._c)

    def snapshot(self) -> dict[str, Any]:
        """A copy of the dynamic state (state vector, dead-time buffer, last input)."""
        return {"x": list(self._x), "buf": list(self._buf), "pos": self._pos, "u": self.u}

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot` of the same plant."""
        if len(snap["x"]) != self.n_states or len(snap["buf"]) != self._buf_len:
            raise ValueError("snapshot does not belong to this plant")
        self._x = [float(v) for v in snap["x"]]
        self._buf = [float(v) for v in snap["buf"]]
        self._pos = int(snap["pos"])
        self.u = float(snap["u"])
        self._y = lti_output(self._x, self._c)

    # -- run-time parameter changes ----------------------------------------------

    _params: ClassVar[tuple[str, ...]] = ()

    def set_parameter(self, name: str, value: Any) -> None:
        """Change a model parameter at run time, keeping the state.

        ``"dead_time"`` works for every linear plant: the input history is
        kept (the newest inputs fill the resized buffer; a longer buffer is
        padded with the oldest value known).  The convenience models also
        accept their own parameters (``k``, ``t``, ``t1``, ``t2``, ``zeta``):
        their states are physical (lag outputs, with the gain at the input), so
        the output does not jump; it moves to the new steady state with the new
        dynamics.  A refused value raises :class:`ParameterError` and leaves
        the model unchanged.
        """
        if name == "dead_time":
            new = require_dead_time(value, self.ts)
            hist = self._history()
            self.dead_time = new
            self._discretise()
            self._rebuffer(hist)
            return
        if name not in self._params:
            known = ", ".join(("dead_time", *self._params))
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                name,
                f"not a run-time parameter of {type(self).__name__} (known: {known})",
            )
        old = getattr(self, name)
        setattr(self, name, self._check(name, value))
        try:
            self.a_c, self.b_c, self.c_c = self._realisation()
        except Exception:
            setattr(self, name, old)
            raise
        self._discretise()
        self._y = lti_output(self._x, self._c)

    def _check(self, name: str, value: Any) -> Any:  # pragma: no cover - overridden
        return value

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        return self.a_c, self.b_c, self.c_c

    def _history(self) -> list[float]:
        """Past inputs in the buffer, newest first."""
        n, pos = self._buf_len, self._pos
        return [self._buf[(pos - 1 - i) % n] for i in range(n)]

    def _rebuffer(self, hist: list[float]) -> None:
        n = self._buf_len
        buf = [0.0] * n
        for i in range(n):
            buf[(-1 - i) % n] = hist[i] if i < len(hist) else hist[-1]
        self._buf, self._pos = buf, 0

    def __repr__(self) -> str:
        dt = f", dead_time={self.dead_time!r}" if self.dead_time else ""
        return (
            f"{type(self).__name__}(n_states={self.n_states}, ts={self.ts!r}{dt}) <y={self._y!r}>"
        )


def _lag(name: str, t: Any) -> float:
    """A lag time constant [s] > 0 whose realisation (``1/t``, ``1/t^2``) is finite."""
    x = require_positive(name, t, ErrorCode.BAD_TIME_CONSTANT)
    if x * x == 0.0 or not math.isfinite(1.0 / (x * x)):
        raise ParameterError(
            ErrorCode.BAD_TIME_CONSTANT, name, f"{t!r} s is too short to model (1/t^2 overflows)"
        )
    return x


class _Model(LinearPlant):
    """A convenience model: named parameters, a physical realisation, ``set_parameter``."""

    def __init__(self, ts: float, dead_time: float) -> None:
        a, b, c = self._realisation()
        super().__init__(A=a, B=b, C=c, ts=ts, dead_time=dead_time)

    def _check(self, name: str, value: Any) -> Any:
        if name == "k":
            return require_finite("k", value)
        if name == "zeta":
            return require_nonnegative("zeta", value)
        if name == "t" and isinstance(getattr(self, "t", None), tuple):
            ts = tuple(_lag(f"t[{i}]", v) for i, v in enumerate(np.atleast_1d(value)))
            if not ts:
                raise ParameterError(ErrorCode.BAD_TIME_CONSTANT, "t", "give at least one")
            return ts
        return _lag(name, value)

    def __repr__(self) -> str:
        args = ", ".join(f"{n}={getattr(self, n)!r}" for n in self._params)
        return f"{type(self).__name__}({args}, ts={self.ts!r}, dead_time={self.dead_time!r})"


def _lag_chain(k: float, t: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Series of lags, states = lag outputs: ``t_i dx_i/dt = x_(i-1) - x_i``, ``x_0 = k u``."""
    n = len(t)
    a = np.zeros((n, n))
    b = np.zeros((n, 1))
    for i, ti in enumerate(t):
        a[i, i] = -1.0 / ti
        if i:
            a[i, i - 1] = 1.0 / ti
    b[0, 0] = k / t[0]
    c = np.zeros((1, n))
    c[0, -1] = 1.0
    return a, b, c


class PT1(_Model):
    """First-order lag ``k e^(-dead_time s) / (t s + 1)`` (controltheplant 2024, ``LSim_PT1``).

    State: the output, ``t dy/dt = k u - y``.

    Parameters
    ----------
    k : float
        Static gain [output unit / input unit].
    t : float
        Time constant [s], > 0.
    ts : float
        Sample time [s].
    dead_time : float
        Input dead time [s], >= 0.
    """

    _params = ("k", "t")

    def __init__(self, k: float, t: float, ts: float, dead_time: float = 0.0) -> None:
        self.k, self.t = require_finite("k", k), _lag("t", t)
        super().__init__(ts, dead_time)

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _lag_chain(self.k, (self.t,))


class FOPDT(PT1):
    """First order plus dead time ``k e^(-dead_time s) / (t s + 1)`` (Nowak et al. 2018, (10)).

    Same as :class:`PT1` with the dead time as a required third argument.
    """

    def __init__(self, k: float, t: float, dead_time: float, ts: float) -> None:
        super().__init__(k, t, ts, dead_time)

    def __repr__(self) -> str:
        return f"FOPDT(k={self.k!r}, t={self.t!r}, dead_time={self.dead_time!r}, ts={self.ts!r})"


class PTn(_Model):
    """Chain of first-order lags ``k e^(-dead_time s) / prod_i (t_i s + 1)``.

    The form of the pneumatic process models (10a) and (10b) of Nowak et al. 2018:
    ``PTn(0.73, (7.3, 2.2, 1.4), ts=0.1)`` is (10b).  States: the outputs of
    the lags in order, the gain at the input (``t_1 dx_1/dt = k u - x_1``,
    ``t_i dx_i/dt = x_(i-1) - x_i``, ``y = x_n``).

    Parameters
    ----------
    k : float
        Static gain.
    t : sequence of float
        Time constants [s], each > 0, at least one; ``set_parameter("t",
        (...))`` must keep their number.
    ts : float
        Sample time [s].
    dead_time : float
        Input dead time [s].
    """

    _params = ("k", "t")

    def __init__(self, k: float, t: Sequence[float], ts: float, dead_time: float = 0.0) -> None:
        self.k = require_finite("k", k)
        self.t: tuple[float, ...] = ()
        self.t = self._check("t", t)
        super().__init__(ts, dead_time)

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if hasattr(self, "_x") and len(self.t) != len(self._x):
            raise ParameterError(ErrorCode.BAD_PARAMETER, "t", "must keep the number of lags")
        return _lag_chain(self.k, self.t)


class PT2(_Model):
    """Second-order lag ``k e^(-dead_time s) / ((t1 s + 1)(t2 s + 1))``.

    States as in :class:`PTn`.
    """

    _params = ("k", "t1", "t2")

    def __init__(self, k: float, t1: float, t2: float, ts: float, dead_time: float = 0.0) -> None:
        self.k, self.t1, self.t2 = require_finite("k", k), _lag("t1", t1), _lag("t2", t2)
        super().__init__(ts, dead_time)

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _lag_chain(self.k, (self.t1, self.t2))


class PT2Osc(_Model):
    """Second-order lag in damping form ``k e^(-dead_time s) / (t^2 s^2 + 2 zeta t s + 1)``.

    States: ``y`` and ``dy/dt``.

    Parameters
    ----------
    k : float
        Static gain.
    t : float
        Time constant ``1/omega_n`` [s], > 0.
    zeta : float
        Damping ratio, >= 0 (``< 1``: oscillating).
    ts : float
        Sample time [s].
    dead_time : float
        Input dead time [s].
    """

    _params = ("k", "t", "zeta")

    def __init__(self, k: float, t: float, zeta: float, ts: float, dead_time: float = 0.0) -> None:
        self.k, self.t = require_finite("k", k), _lag("t", t)
        self.zeta = require_nonnegative("zeta", zeta)
        super().__init__(ts, dead_time)

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        w2 = 1.0 / (self.t * self.t)
        a = np.array([[0.0, 1.0], [-w2, -2.0 * self.zeta / self.t]])
        return a, np.array([[0.0], [self.k * w2]]), np.array([[1.0, 0.0]])


class IT1(_Model):
    """Integrator with lag ``k e^(-dead_time s) / (s (t s + 1))`` (controltheplant 2024).

    ``LSim_IT1`` of controltheplant 2024.

    States: the lag output ``x`` (``t dx/dt = k u - x``) and ``y`` (``dy/dt = x``).
    Integrating: ``reset(u0)`` gives the zero state (the output stays at 0 only
    for ``u0 = 0``; otherwise it ramps with slope ``k u0``).

    Parameters
    ----------
    k : float
        Integration gain [output unit / (input unit s)].
    t : float
        Lag time constant [s], > 0.
    ts : float
        Sample time [s].
    dead_time : float
        Input dead time [s].
    """

    _params = ("k", "t")

    def __init__(self, k: float, t: float, ts: float, dead_time: float = 0.0) -> None:
        self.k, self.t = require_finite("k", k), _lag("t", t)
        super().__init__(ts, dead_time)

    def _realisation(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a = np.array([[-1.0 / self.t, 0.0], [1.0, 0.0]])
        return a, np.array([[self.k / self.t], [0.0]]), np.array([[0.0, 1.0]])
