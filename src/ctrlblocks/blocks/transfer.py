"""Discrete transfer function as a cascade of biquads, with low-pass and notch designs.

The block :class:`TransferFunction` runs ``H(z) = H_1(z) H_2(z) ... H_m(z)``, a
cascade of ``m <= 8`` second-order sections (biquads)::

    H_j(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2)

each in the transposed direct form II (Oppenheim & Schafer 2010, section 6.4,
transposed forms; the cascade form is their section 6.3)::

    y    = b0 u + s1
    s1' = b1 u - a1 y + s2
    s2' = b2 u - a2 y

the output of one section being the input of the next.  A cascade of
sections is how a filter of higher order is run in finite precision (the
poles of one section move little when its two coefficients round; those of a
direct form of high order move a lot -- Oppenheim & Schafer 2010, the
sections on coefficient quantization); it is scipy's ``sos`` form without the
``a0 = 1`` column.  A first-order
section has ``b2 = a2 = 0``.

Design helpers (pure functions returning the sections)
------------------------------------------------------
All use the bilinear (Tustin) transform ``s = (2/h)(z - 1)/(z + 1)`` with the
frequency prewarped so that the digital filter has exactly the analog one's
response at the design frequency ``w``: ``w_a = (2/h) tan(w h / 2)``
(Oppenheim & Schafer 2010, section 7.2.2, the bilinear transformation and its
frequency warping):

* :func:`lowpass` -- Butterworth of order 1..8, cut-off ``w`` [rad/s]: the
  analog prototype's pole pairs have ``Q_k = 1 / (2 cos(pi (n - 2k + 1)/(2n)))``
  (Oppenheim & Schafer 2010, section 7.3: the ``2n`` poles of ``|H|^2`` evenly
  on the circle of radius ``w``), one first-order section for odd ``n``; ``|H| =
  1/sqrt(2)`` at ``w`` for every order.  The same filter as
  ``scipy.signal.butter(n, w, fs=1/h)`` in rad/s (tested).
* :func:`notch` -- ``(s^2 + 2 zeta_z w s + w^2) / (s^2 + (w/Q) s + w^2)``,
  notch frequency ``w`` [rad/s] and ``Q`` as Rockwell's NTCH instruction
  defines them (``WNotch`` in rad/s, ``QFactor = 1/(2 zeta)``, Rockwell
  1756-RM006, "Notch Filter (NTCH)"); ``depth`` is the gain left at ``w``
  (``zeta_z = depth/(2 Q)``; 0: a full notch).  With ``depth = 0`` it is the
  "notch" biquad of Bristow-Johnson's cookbook.
* :func:`tustin` -- any analog transfer function of order <= 2 as one section.

Run-time behaviour
------------------
* ``init=True`` starts the filter at rest at the present input: the memory
  is the steady state of a constant input (output = DC gain x input), as
  Rockwell's filter instructions' ``Initialize`` ("sets Out = In" for their
  unity-gain filters).  :meth:`TransferFunction.preset` does the same at once.
* Output limits ``out_min <= out <= out_max`` limit the output only; the
  sections run on linearly (a filter has no windup to prevent).
* A NaN/inf input (or one beyond the REAL range) holds the output and the
  memory, ``BAD_INPUT``.  A sample whose memory would leave the REAL range
  (a stable filter driven by huge finite inputs) holds the output, clears
  the memory and sets ``BAD_RESULT``; the next valid input continues from
  rest.
* The coefficients are discrete, for the configured ``ts``: the block takes
  no per-call ``dt``.  Only stable sections are accepted (both poles inside
  the unit circle: ``|a2| < 1`` and ``|a1| < 1 + a2``, the stability triangle
  of a second-order polynomial).

The sample is one pure function, :func:`transfer_cycle`, in the subset the PLC
translator accepts (arrays of the sections' coefficients and memory): the
block, its ``precision="float32"`` lane and the exported ``CB_TRANSFER`` run it.
"""

from __future__ import annotations

import cmath
import dataclasses
import math
from collections.abc import Sequence
from typing import Any, ClassVar

from .base import (
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_flag,
    as_input,
    require_finite,
    require_limits,
    require_positive,
)
from .cycleblock import CycleBlock, float_rows, real_limit, require_precision
from .plc_cycle import is_real

__all__ = [
    "MAX_SECTIONS",
    "TRANSFER_RESULTS",
    "Section",
    "TransferFunction",
    "TransferFunctionConfig",
    "dc_gain",
    "frequency_response",
    "lowpass",
    "notch",
    "transfer_cycle",
    "tustin",
]

Section = tuple[float, float, float, float, float]
"""``(b0, b1, b2, a1, a2)`` of one biquad (``a0 = 1``)."""

MAX_SECTIONS = 8
"""The most sections a :class:`TransferFunction` runs (order 16)."""

NO_ERROR = int(ErrorCode.NO_ERROR)
BAD_INPUT = int(ErrorCode.BAD_INPUT)
BAD_RESULT = int(ErrorCode.BAD_RESULT)


# ---------------------------------------------------------------------------
# Design helpers
# ---------------------------------------------------------------------------


def _prewarp(w: float, h: float) -> float:
    """``cot(w h / 2)``: the bilinear transform's ``s / w_a`` factor (module docstring)."""
    if not 0.0 < w * h < math.pi:
        raise ParameterError(
            ErrorCode.BAD_PARAMETER,
            "w",
            f"must lie in (0, pi/ts) = (0, {math.pi / h:.6g}) rad/s, got {w!r}",
        )
    return 1.0 / math.tan(0.5 * w * h)


def tustin(
    num: Sequence[float], den: Sequence[float], ts: float, w_warp: float | None = None
) -> Section:
    """One section from an analog ``num(s)/den(s)`` of order <= 2 by the bilinear transform.

    ``num`` and ``den`` in descending powers of ``s`` (scipy's order), at most 3
    coefficients each.  ``w_warp`` [rad/s]: prewarp so that the response at
    ``w_warp`` is exact (Oppenheim & Schafer 2010, section 7.2.2); None: plain
    Tustin ``s = (2/ts)(z - 1)/(z + 1)``.
    """
    h = require_positive("ts", ts, ErrorCode.NO_CYCLE)
    if not (1 <= len(num) <= 3 and 1 <= len(den) <= 3):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "num/den", "at most second order each")
    n2, n1, n0 = (0.0,) * (3 - len(num)) + tuple(float(v) for v in num)
    d2, d1, d0 = (0.0,) * (3 - len(den)) + tuple(float(v) for v in den)
    k = 2.0 / h if w_warp is None else w_warp * _prewarp(w_warp, h)

    # s = k (1 - q)/(1 + q), q = z^-1: multiply through by (1 + q)^2
    def poly(c2: float, c1: float, c0: float) -> tuple[float, float, float]:
        kk = k * k
        return (c2 * kk + c1 * k + c0, 2.0 * (c0 - c2 * kk), c2 * kk - c1 * k + c0)

    if n2 == 0.0 and d2 == 0.0:
        # first order: multiply through by (1 + q) only (no pole-zero pair at z = -1)
        b0, b1, b2 = n1 * k + n0, n0 - n1 * k, 0.0
        a0, a1, a2 = d1 * k + d0, d0 - d1 * k, 0.0
    else:
        b0, b1, b2 = poly(n2, n1, n0)
        a0, a1, a2 = poly(d2, d1, d0)
    if a0 == 0.0 or not math.isfinite(a0):
        raise ParameterError(ErrorCode.BAD_PARAMETER, "den", "gives a0 = 0 (a pole at z = -1)")
    return (b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0)


def lowpass(w: float, ts: float, order: int = 2) -> tuple[Section, ...]:
    """Butterworth low-pass of ``order`` 1..8 with cut-off ``w`` [rad/s], prewarped Tustin.

    Sections ordered by rising Q (the most damped first), the first-order one
    (odd ``order``) first.  ``|H(e^(j w ts))| = 1/sqrt(2)``; DC gain 1.
    """
    h = require_positive("ts", ts, ErrorCode.NO_CYCLE)
    if type(order) is not int or not 1 <= order <= 2 * MAX_SECTIONS:
        raise ParameterError(ErrorCode.BAD_ORDER, "order", f"must be 1..16, got {order!r}")
    c = _prewarp(w, h)
    out: list[Section] = []
    if order % 2:
        out.append((1.0 / (c + 1.0), 1.0 / (c + 1.0), 0.0, (1.0 - c) / (c + 1.0), 0.0))
    for k in range(order // 2, 0, -1):
        # the pole pair at the angle pi (n - 2k + 1)/(2n) from the negative real axis
        q = 1.0 / (2.0 * math.cos(math.pi * (order - 2 * k + 1) / (2 * order)))
        out.append(_second_order(c, 1.0 / q, 0.0, 0.0, 1.0))
    return tuple(out)


def notch(w: float, q: float, ts: float, depth: float = 0.0) -> Section:
    """Notch at ``w`` [rad/s] with quality ``q`` (pole damping ``1/(2q)``), prewarped Tustin.

    ``depth`` in [0, 1): the gain at ``w`` (0: a full notch); DC and high-frequency
    gain 1.  Rockwell's NTCH instruction (1756-RM006) defines ``WNotch`` and
    ``QFactor`` so.
    """
    h = require_positive("ts", ts, ErrorCode.NO_CYCLE)
    qq = require_positive("q", q)
    dd = require_finite("depth", depth)
    if not 0.0 <= dd < 1.0:
        raise ParameterError(ErrorCode.BAD_PARAMETER, "depth", f"must lie in [0, 1), got {depth!r}")
    c = _prewarp(w, h)
    return _second_order(c, 1.0 / qq, 1.0, dd / qq, 1.0)


def _second_order(c: float, den1: float, num2: float, num1: float, num0: float) -> Section:
    """Bilinear image of ``(num2 x^2 + num1 x + num0) / (x^2 + den1 x + 1)``, ``x = s/w_a``,
    with ``x = c (1 - q)/(1 + q)``."""
    cc = c * c
    a0 = cc + den1 * c + 1.0
    b0 = num2 * cc + num1 * c + num0
    b1 = 2.0 * (num0 - num2 * cc)
    b2 = num2 * cc - num1 * c + num0
    return (b0 / a0, b1 / a0, b2 / a0, 2.0 * (1.0 - cc) / a0, (cc - den1 * c + 1.0) / a0)


def frequency_response(sections: Sequence[Sequence[float]], w: float, ts: float) -> complex:
    """``H(e^(j w ts))`` of the cascade at ``w`` [rad/s]."""
    q = cmath.exp(-1j * w * ts)
    out = complex(1.0)
    for b0, b1, b2, a1, a2 in sections:
        out *= (b0 + b1 * q + b2 * q * q) / (1.0 + a1 * q + a2 * q * q)
    return out


def dc_gain(sections: Sequence[Sequence[float]]) -> float:
    """``H(1)``: the steady-state gain of the cascade."""
    g = 1.0
    for b0, b1, b2, a1, a2 in sections:
        g *= (b0 + b1 + b2) / (1.0 + a1 + a2)
    return g


# ---------------------------------------------------------------------------
# The cycle (the PLC translator's subset)
# ---------------------------------------------------------------------------

TRANSFER_RESULTS = ("out", "error_id", "y", "z1", "z2")
"""Names of the values :func:`transfer_cycle` returns: outputs, then the new memory."""


def transfer_cycle(
    x: float,
    init: bool,
    b0: list[float],
    b1: list[float],
    b2: list[float],
    a1: list[float],
    a2: list[float],
    out_min: float,
    out_max: float,
    y: float,
    z1: list[float],
    z2: list[float],
) -> tuple[float, int, float, list[float], list[float]]:
    """One sample of :class:`TransferFunction` (module docstring).

    ``y`` is the unlimited output of the last valid sample, ``z1``/``z2`` the
    sections' memory (transposed direct form II).  Returns :data:`TRANSFER_RESULTS`.
    """
    err = NO_ERROR
    if not is_real(x):
        err = BAD_INPUT
    else:
        u = x
        if init:
            # at rest at this input: every section in its steady state
            for j in range(len(b0)):
                g = (b0[j] + b1[j] + b2[j]) / (1.0 + a1[j] + a2[j])
                v = g * u
                z1[j] = v - b0[j] * u
                z2[j] = b2[j] * u - a2[j] * v
                u = v
            u = x
        ok = True
        for j in range(len(b0)):
            v = b0[j] * u + z1[j]
            z1[j] = b1[j] * u - a1[j] * v + z2[j]
            z2[j] = b2[j] * u - a2[j] * v
            if not (is_real(v) and is_real(z1[j]) and is_real(z2[j])):
                ok = False
            u = v
        if ok:
            y = u
        else:
            # the memory left the REAL range: hold the output, continue from rest
            err = BAD_RESULT
            for j in range(len(b0)):
                z1[j] = 0.0
                z2[j] = 0.0
    out = y
    if out < out_min:
        out = out_min
    if out > out_max:
        out = out_max
    return out, err, y, z1, z2


# ---------------------------------------------------------------------------
# The block
# ---------------------------------------------------------------------------


def _stable(a1: float, a2: float) -> bool:
    """Both roots of ``z^2 + a1 z + a2`` inside the unit circle (the stability triangle)."""
    return abs(a2) < 1.0 and abs(a1) < 1.0 + a2


@dataclasses.dataclass(frozen=True)
class TransferFunctionConfig(BlockConfig):
    """Configuration of :class:`TransferFunction`.

    Attributes
    ----------
    sections : tuple of (b0, b1, b2, a1, a2)
        The biquads, 1 .. :data:`MAX_SECTIONS` (from :func:`lowpass`,
        :func:`notch`, :func:`tustin` or your own design); each stable.
    ts : float
        The sample time [s] the coefficients are designed for (the block is
        called once per ``ts``).
    out_min, out_max : float
        Output limits (infinite: none).
    precision : str
        ``"float64"`` or ``"float32"`` (the cycle as a PLC's REAL computes it).
    """

    sections: tuple[tuple[float, float, float, float, float], ...] = ((1.0, 0.0, 0.0, 0.0, 0.0),)
    ts: float = 0.1
    out_min: float = -math.inf
    out_max: float = math.inf
    precision: str = "float64"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "sections", float_rows(self.sections))

    def validate(self) -> None:
        s = self.sections
        if not isinstance(s, tuple) or not 1 <= len(s) <= MAX_SECTIONS:
            raise ParameterError(
                ErrorCode.BAD_PARAMETER,
                "sections",
                f"must be 1..{MAX_SECTIONS} sections, got {s!r}",
            )
        for j, row in enumerate(s):
            field = f"sections[{j}]"
            if not isinstance(row, tuple) or len(row) != 5:
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, field, f"must be (b0, b1, b2, a1, a2), got {row!r}"
                )
            for name, v in zip(("b0", "b1", "b2", "a1", "a2"), row, strict=True):
                x = require_finite(f"{field}.{name}", v)
                if abs(x) > 1e30:
                    raise ParameterError(
                        ErrorCode.BAD_PARAMETER,
                        f"{field}.{name}",
                        f"must be within 1e30, got {v!r}",
                    )
            if not _stable(row[3], row[4]):
                raise ParameterError(
                    ErrorCode.BAD_PARAMETER, field,
                    f"has a pole on or outside the unit circle (a1 = {row[3]!r}, a2 = {row[4]!r})",
                )  # fmt: skip
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        require_limits("out_min", self.out_min, "out_max", self.out_max)
        require_precision(self)


class TransferFunction(CycleBlock):
    """Discrete transfer function, a cascade of biquads (see the module docstring).

    ``y = tf(x)`` runs one sample; ``tf(x, init=True)`` starts at rest at ``x``.

    Examples
    --------
    A 2nd-order Butterworth low-pass at 1 rad/s, sampled at 0.1 s, started at
    rest at 2.0: the output stays at 2.0 (DC gain 1).

    >>> tf = TransferFunction(sections=lowpass(1.0, 0.1, order=2), ts=0.1)
    >>> round(tf(2.0, init=True), 12)
    2.0

    A notch at 5 rad/s removes a 5 rad/s sine after its transient:

    >>> import math
    >>> nf = TransferFunction(sections=(notch(5.0, 2.0, 0.01),), ts=0.01)
    >>> ys = [nf(math.sin(5.0 * 0.01 * k)) for k in range(4000)]
    >>> max(abs(v) for v in ys[-500:]) < 1e-6
    True
    """

    Config = TransferFunctionConfig
    config: TransferFunctionConfig
    _config: TransferFunctionConfig
    _cycle = staticmethod(transfer_cycle)
    _results = TRANSFER_RESULTS
    _process: ClassVar[dict[str, Any]] = {"x": 0.0, "init": False}
    _outputs: ClassVar[dict[str, Any]] = {"out": 0.0, "error_id": 0}

    def _parameters(self) -> dict[str, Any]:
        c = self._config
        cols = list(zip(*c.sections, strict=True))
        return {"b0": list(cols[0]), "b1": list(cols[1]), "b2": list(cols[2]),
                "a1": list(cols[3]), "a2": list(cols[4]),
                "out_min": real_limit(c.out_min), "out_max": real_limit(c.out_max)}  # fmt: skip

    def _initial(self) -> dict[str, Any]:
        n = len(self._config.sections)
        return {"y": 0.0, "z1": [0.0] * n, "z2": [0.0] * n}

    def _initial_out(self) -> float:
        return min(max(0.0, real_limit(self._config.out_min)), real_limit(self._config.out_max))

    def _reconfigured(self, old: BlockConfig) -> None:
        if len(self._config.sections) != len(old.sections):  # type: ignore[attr-defined]
            self._mem = self._initial()  # another structure: start at rest
        self.out = min(max(self.out, self._prm["out_min"]), self._prm["out_max"])

    def output_limits(self) -> tuple[float, float]:
        """``(out_min, out_max)`` in force (infinite limits as +-3.402823E38)."""
        return self._prm["out_min"], self._prm["out_max"]

    @property
    def y(self) -> float:
        """The unlimited output of the last valid sample."""
        return float(self._mem["y"])

    def dc_gain(self) -> float:
        """The steady-state gain ``H(1)``."""
        return dc_gain(self._config.sections)

    def frequency_response(self, w: float) -> complex:
        """``H(e^(j w ts))`` at ``w`` [rad/s]."""
        return frequency_response(self._config.sections, w, float(self._config.ts))

    def preset(self, x: float) -> None:
        """Start at rest at the input ``x`` now (as ``init=True`` does in a sample)."""
        if is_real(as_input(x)):
            self(x, init=True)

    def __call__(self, x: float, *, init: Any = False) -> float:
        """One sample of input ``x``; return the output."""
        res = self._run({"x": as_input(x), "init": as_flag(init, False)}, float(self._config.ts))
        self.out = float(res["out"])
        return self.out
