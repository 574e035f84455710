"""Ratio station: the setpoint of a flow loop as a ratio times a wild flow.

The ratio structure (:class:`RatioStructure`)
keeps a controlled flow ``y`` in a given ratio to a *wild* flow ``w`` that
it measures but does not manipulate (a blending or a burner's air/fuel
loop).  The ratio station turns the requested ratio ``r`` (the structure's
setpoint input) and the wild flow into the flow loop's setpoint ::

    sp_flow = bias + r_w w                                             (R1)

where ``r_w`` is the *working ratio*.  Per sample ``h``:

* **ratio limits** -- the requested ratio is limited to ``[r_min, r_max]``
  (``limited`` is set while it is outside); a non-finite request keeps the
  last one (``BAD_INPUT``);
* **bumpless ratio changes** -- the working ratio moves towards the limited
  request at most ``rate h`` per sample (``rate = inf``, the default: at
  once);
* **bad wild flow** -- a wild flow whose quality flag is false
  (``BAD_MEASUREMENT``) or that is not finite (``BAD_INPUT``) holds the last
  good setpoint, with ``holding`` set; before any good sample the setpoint
  is NaN, which the controller holds on (its ``BAD_INPUT`` rule);
* **recovery** -- when the wild flow is good again the working ratio is
  back-calculated from the held setpoint, ``r_w = (sp_flow - bias) / w``
  (limited to ``[r_min, r_max]``; a zero wild flow takes the request), so
  the setpoint continues from the held value and then follows the request
  at ``rate`` -- no bump unless ``rate`` is infinite.

None of the sources ctrlblocks implements treats ratio control: these rules
are ctrlblocks' design, stated here and tested (tests/loops/test_split_ratio.py).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from ..blocks.base import ErrorCode, ParameterError, require_finite, require_positive
from ..blocks.signals import clamp
from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Stage, Wiring

__all__ = ["RatioConfig", "RatioStage", "RatioStation", "RatioStructure"]


@dataclasses.dataclass(frozen=True)
class RatioConfig:
    """Configuration of a :class:`RatioStation`.

    Attributes
    ----------
    r_min, r_max : float
        Ratio limits [controlled flow units / wild flow units].
    bias : float
        Added to the setpoint [controlled flow units].
    rate : float
        Largest change of the working ratio [ratio units / s], > 0; inf: at once.
    ts : float
        Sample time [s].
    """

    r_min: float = 0.0
    r_max: float = math.inf
    bias: float = 0.0
    rate: float = math.inf
    ts: float = 1.0

    def __post_init__(self) -> None:
        lo = float(self.r_min)
        hi = float(self.r_max)
        if not (math.isfinite(lo) and not math.isnan(hi) and lo <= hi):
            raise ParameterError(
                ErrorCode.BAD_LIMITS, "r_min", f"must be finite and <= r_max, got {self.r_min!r}"
            )
        require_finite("bias", self.bias)
        if not (float(self.rate) > 0):
            raise ParameterError(ErrorCode.BAD_RATE, "rate", f"must be > 0, got {self.rate!r}")
        require_positive("ts", self.ts, ErrorCode.NO_CYCLE)


class RatioStation:
    """The ratio station of the module docstring.

    Parameters
    ----------
    config : RatioConfig, optional
        Or its fields as keywords.

    Attributes
    ----------
    sp : float
        The setpoint of the last sample (NaN before the first good wild flow).
    ratio : float
        The working ratio ``r_w`` (NaN before the first good sample).
    wild : float
        The last good wild flow.
    holding : bool
        True while a bad wild flow holds the setpoint.
    limited : bool
        True while the requested ratio is outside ``[r_min, r_max]``.
    error_id : ErrorCode
        ``NO_ERROR``, ``BAD_MEASUREMENT`` or ``BAD_INPUT`` of the last sample.

    >>> st = RatioStation(r_min=0.5, r_max=2.0, ts=1.0)
    >>> st(1.5, 10.0), st(3.0, 10.0), st.limited
    (15.0, 20.0, True)
    >>> st(1.5, math.nan), st.holding
    (20.0, True)
    """

    _state = ("sp", "ratio", "wild", "request", "holding", "limited", "error_id")

    def __init__(self, config: RatioConfig | None = None, /, **params: Any) -> None:
        self.config = config if config is not None else RatioConfig(**params)
        self.reset()

    def reset(self) -> None:
        """Back to the state before the first sample."""
        self.sp = math.nan
        self.ratio = math.nan
        self.wild = math.nan
        self.request = math.nan
        self.holding = False
        self.limited = False
        self.error_id = ErrorCode.NO_ERROR

    def snapshot(self) -> dict[str, Any]:
        """A copy of the state (:meth:`restore` puts it back)."""
        return {k: getattr(self, k) for k in self._state}

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        for k in self._state:
            setattr(self, k, snap[k])
        self.error_id = ErrorCode(int(self.error_id))

    def __call__(
        self, ratio: float, wild: float, wild_ok: bool = True, dt: float | None = None
    ) -> float:
        """One sample: the requested ``ratio`` and the wild flow -> the flow setpoint (R1)."""
        c = self.config
        h = c.ts if dt is None or not (math.isfinite(dt) and dt > 0) else float(dt)
        self.error_id = ErrorCode.NO_ERROR
        if isinstance(ratio, (int, float)) and math.isfinite(ratio):
            self.request = float(ratio)
        else:
            self.error_id = ErrorCode.BAD_INPUT
        req = self.request
        self.limited = math.isfinite(req) and not (c.r_min <= req <= c.r_max)
        target = clamp(req, c.r_min, c.r_max) if math.isfinite(req) else self.ratio
        good = bool(wild_ok) and isinstance(wild, (int, float)) and math.isfinite(wild)
        if not good:
            self.error_id = ErrorCode.BAD_MEASUREMENT if not wild_ok else ErrorCode.BAD_INPUT
            self.holding = True
            return self.sp
        w = float(wild)
        if self.holding and math.isfinite(self.sp) and w != 0.0:
            # back from a bad wild flow: continue from the held setpoint
            self.ratio = clamp((self.sp - c.bias) / w, c.r_min, c.r_max)
        self.holding = False
        self.wild = w
        if not math.isfinite(self.ratio):
            self.ratio = target
        elif math.isfinite(target):
            step = c.rate * h
            d = target - self.ratio
            self.ratio = target if abs(d) <= step else self.ratio + math.copysign(step, d)
        if math.isfinite(self.ratio):
            self.sp = c.bias + self.ratio * w
        return self.sp

    def __repr__(self) -> str:
        return f"RatioStation({self.config!r})"


class RatioStage(Stage):
    """The ratio station before the flow controller: the flow setpoint ``sp_flow`` (R1)."""

    name = "ratio"
    signals = ("sp_flow", "ratio", "wild", "wild_hold", "ratio_limited")
    measurements = ("w",)

    def setup(self, side):
        side.parts[self.name] = RatioStation(side.spec.options["ratio"])

    def compute(self, side, sp, m, signals):
        st: RatioStation = side.parts[self.name]
        signals["sp_flow"] = st(sp, m.w, m.w_ok, m.dt)
        signals["ratio"] = st.ratio
        signals["wild"] = st.wild
        signals["wild_hold"] = float(st.holding)
        signals["ratio_limited"] = float(st.limited)


class RatioStructure(Structure):
    """Ratio control: the station's ``bias + r w`` is the flow loop's setpoint (module docstring).

    The structure's setpoint input is the requested *ratio*; ``w`` is the
    wild flow and ``y`` the controlled flow.  The entry has the flow
    controller ``main`` and the station table ``ratio`` (``r_min``,
    ``r_max``, ``bias``, ``rate`` of :class:`RatioConfig`).
    Signals: ``sp_flow`` (the flow setpoint), ``ratio`` (the working ratio),
    ``wild`` (the last good wild flow), ``wild_hold`` (1 while a bad wild
    flow holds the setpoint) and ``ratio_limited`` (1 while the request is
    outside the ratio limits).
    """

    name = "ratio"
    roles = ("main",)
    options = ("ratio",)
    measurements = ("y", "w")
    setpoint_signal = "sp_flow"
    wiring = Wiring((Loop("main", sp="sp_flow"),), stages=(RatioStage(),), measured_mv=True)

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, "main", "ratio"}, key)
        main = r.role(e, "main", key, ts, tune)
        table = r.table(e, "ratio", f"{key}.ratio", False)
        r.check_keys(table, {"r_min", "r_max", "bias", "rate"}, f"{key}.ratio")
        kw = {}
        for name in ("r_min", "r_max", "bias", "rate"):
            if name in table:
                kw[name] = r.number(table, name, f"{key}.ratio.{name}",
                                   limit=name in ("r_max", "rate"))  # inf: no limit
        try:
            cfg = RatioConfig(**kw, ts=ts)
        except ParameterError as exc:
            raise r.fail(f"{key}.ratio.{exc.field}", exc.message) from None
        return {"main": main}, {"ratio": cfg}
