"""Cycle-time monitor: statistics of the measured cycle time, warning and alarm flags.

Source
------
Bonde et al. 2021 (NTNU working note, section "Valg av samplingstid"): the sample time
should be as short as possible but, above all, predictable, because the
filters' behaviour depends on it; the authors therefore made "a separate
function block that monitors the sample time", used to find a suitable sample
time, "equipped with an alarm/warning if the real sample time exceeds a
user-defined level".  The note gives no code for it; this block is
ctrlblocks' design from that description.

Like every block, the monitor reads no clock: the caller (the runtime's
scheduler, a test, a replay of a log) passes the measured cycle time of each
cycle, ``mon(dt_measured)``.

Outputs (all in seconds unless said otherwise), over the valid cycles since
``reset()``:

* ``count``: number of valid cycles; ``out``: the last valid cycle time;
* ``min``, ``max``, ``mean``: smallest, largest and arithmetic mean cycle time
  (0 until the first valid cycle);
* ``jitter_std``: population standard deviation of the cycle time,
  ``sqrt(sum((dt_i - mean)^2) / count)`` (Welford's running update, so no
  history is kept, with the sum of squares kept scaled so that it stays finite
  for any finite cycle time: :func:`welford_scaled_update`);
* ``jitter_max``: largest deviation from the configured cycle time,
  ``max |dt_i - ts|``;
* ``warning``: the last cycle time was above ``warn_limit``; ``alarm``: above
  ``alarm_limit`` (``alarm_limit >= warn_limit``, so every alarm is also a
  warning).  With ``latch=True`` both stay set until :meth:`CycleMonitor.acknowledge`,
  which sets them back to the live condition (the last valid cycle time against
  the limits in force): a flag whose cause is still present stays set, and
  without ``latch`` it changes nothing;
* ``overruns``: number of cycles above ``warn_limit``; ``alarms``: number of
  cycles above ``alarm_limit``;
* ``invalid``: number of calls with an unusable measurement (see below).

Errors
------
A measured cycle time that is NaN, infinite, zero or negative sets
``NO_CYCLE`` (``error_id``), is not counted in any statistic, and leaves the
flags as they were; the next valid measurement clears the error.  Invalid
configuration (non-positive ``ts`` -> ``NO_CYCLE``; non-positive or non-finite
limits, or ``alarm_limit < warn_limit`` -> ``BAD_LIMITS``) is refused.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .base import (
    Block,
    BlockConfig,
    ErrorCode,
    ParameterError,
    as_input,
    require_bool,
    require_positive,
)

__all__ = ["CycleMonitor", "CycleMonitorConfig", "welford_scaled_update", "welford_update"]


def welford_scaled_update(
    n: int, mean: float, scale: float, q: float, x: float
) -> tuple[int, float, float, float]:
    """Welford's update (:func:`welford_update`) with ``m2`` kept as ``scale**2 * q``.

    ``scale`` is the largest ``|x - mean_{n-1}|`` seen, ``q = m2 / scale**2``:
    the squares are never formed unscaled, so ``m2`` cannot overflow however
    large the values (the scaled sum of squares of LAPACK's ``dnrm2``; a plain
    ``m2`` is +inf from deviations of ~1.3e154 on, and the standard deviation
    with it).  The population standard deviation after ``n`` values is
    ``scale * sqrt(q / n)``.
    """
    n += 1
    d = x - mean
    mean += d / n
    ad = abs(d)
    if ad > scale:
        q = q * (scale / ad) * (scale / ad)
        scale = ad
    if scale > 0.0:
        q += (d / scale) * ((x - mean) / scale)
    return n, mean, scale, q


def welford_update(n: int, mean: float, m2: float, x: float) -> tuple[int, float, float]:
    """One step of Welford's running mean and sum of squared deviations ``m2``.

    ``mean_n = mean_{n-1} + (x - mean_{n-1})/n``, ``m2_n = m2_{n-1} + (x -
    mean_{n-1})(x - mean_n)`` (B. P. Welford, Technometrics 4 (1962) 419-420;
    not from the sources).  The population variance after ``n`` values is ``m2 / n``.
    """
    n += 1
    d = x - mean
    mean += d / n
    m2 += d * (x - mean)
    return n, mean, m2


@dataclasses.dataclass(frozen=True)
class CycleMonitorConfig(BlockConfig):
    """Configuration of :class:`CycleMonitor`.

    Attributes
    ----------
    ts : float
        Configured (nominal) cycle time [s] > 0; ``jitter_max`` is measured
        from it.
    warn_limit : float, optional
        Warning above this cycle time [s] > 0; default ``1.5 ts``.
    alarm_limit : float, optional
        Alarm above this cycle time [s], >= ``warn_limit``; default ``2 ts``
        (a missed cycle).
    latch : bool
        Keep ``warning``/``alarm`` set until :meth:`CycleMonitor.acknowledge`.
    """

    ts: float = 0.1
    warn_limit: float | None = None
    alarm_limit: float | None = None
    latch: bool = False

    def validate(self) -> None:
        ts = require_positive("ts", self.ts, ErrorCode.NO_CYCLE)
        warn, alarm = self.limits(ts)
        require_positive("warn_limit", warn, ErrorCode.BAD_LIMITS)
        require_positive("alarm_limit", alarm, ErrorCode.BAD_LIMITS)
        if alarm < warn:
            raise ParameterError(
                ErrorCode.BAD_LIMITS,
                "warn_limit/alarm_limit",
                f"alarm limit {alarm!r} is below the warning limit {warn!r}",
            )
        require_bool("latch", self.latch)

    def limits(self, ts: float | None = None) -> tuple[float, float]:
        """The warning and alarm limits in force [s] (defaults resolved)."""
        ts = float(self.ts) if ts is None else ts
        warn = 1.5 * ts if self.warn_limit is None else self.warn_limit
        alarm = 2.0 * ts if self.alarm_limit is None else self.alarm_limit
        return warn, alarm


class CycleMonitor(Block):
    """Monitor of the real cycle time (Bonde et al. 2021, "Valg av samplingstid").

    See the module docstring.

    ``mon(dt_measured)`` records one cycle and returns ``warning`` (true when
    the cycle time exceeded ``warn_limit``, which includes every alarm).

    Examples
    --------
    >>> mon = CycleMonitor(ts=0.010, warn_limit=0.012, alarm_limit=0.020)
    >>> [mon(dt) for dt in (0.010, 0.011, 0.013, 0.009, 0.025)]
    [False, False, True, False, True]
    >>> mon.alarm, mon.overruns, mon.alarms, round(mon.max, 6), round(mon.mean, 6)
    (True, 2, 1, 0.025, 0.0136)
    """

    Config = CycleMonitorConfig
    _state_fields = (
        "out",
        "count",
        "mean",
        "_scale",
        "_q",
        "min",
        "max",
        "jitter_max",
        "overruns",
        "alarms",
        "invalid",
        "warning",
        "alarm",
    )
    config: CycleMonitorConfig
    _config: CycleMonitorConfig
    warning: bool
    alarm: bool
    count: int

    def _apply_config(self, old: BlockConfig | None) -> None:
        c = self._config
        self._ts = float(c.ts)
        warn, alarm = c.limits()
        self._warn, self._alarm = float(warn), float(alarm)
        self._latch = c.latch
        if old is not None:  # new limits: the flags follow the last cycle time against them
            self._flag(*self._live())

    def _live(self) -> tuple[bool, bool]:
        """The live condition: the last valid cycle time against the limits in force."""
        seen = self.count > 0
        return seen and self.out > self._warn, seen and self.out > self._alarm

    def _flag(self, warning: bool, alarm: bool) -> None:
        """Set the flags to a condition (latched: a set flag stays set)."""
        if self._latch:
            self.warning = self.warning or warning
            self.alarm = self.alarm or alarm
        else:
            self.warning, self.alarm = warning, alarm

    def _reset_state(self) -> None:
        self.out = 0.0
        self.count = 0
        self.mean = 0.0
        self._scale = 0.0  # m2 = _scale**2 * _q (welford_scaled_update)
        self._q = 0.0
        self.min = 0.0
        self.max = 0.0
        self.jitter_max = 0.0
        self.overruns = 0
        self.alarms = 0
        self.invalid = 0
        self.warning = False
        self.alarm = False

    @property
    def warn_limit(self) -> float:
        """Warning limit in force [s]."""
        return self._warn

    @property
    def alarm_limit(self) -> float:
        """Alarm limit in force [s]."""
        return self._alarm

    @property
    def jitter_std(self) -> float:
        """Population standard deviation of the valid cycle times [s] (0 before two cycles)."""
        return self._scale * math.sqrt(self._q / self.count) if self.count else 0.0

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Restore a :meth:`snapshot`; one of before the scaled sum (``_m2``) is converted."""
        if "_m2" in snapshot and "_q" not in snapshot:
            m2 = float(snapshot["_m2"])
            root = math.sqrt(m2) if m2 > 0.0 else 0.0
            snapshot = {**snapshot, "_scale": root, "_q": 1.0 if root > 0.0 else 0.0}
        super().restore(snapshot)

    def acknowledge(self) -> None:
        """Clear latched ``warning``/``alarm`` flags whose cause is gone (statistics are kept).

        The flags take the live condition: the last valid cycle time against
        the limits in force.  A flag that is still true stays set; without
        ``latch`` the flags already are the live condition and do not change.
        """
        self.warning, self.alarm = self._live()

    def __call__(self, dt_measured: float) -> bool:
        """Record one measured cycle time [s]; return ``warning``."""
        dt = as_input(dt_measured)
        if not (math.isfinite(dt) and dt > 0.0):
            self.error_id = ErrorCode.NO_CYCLE
            self.invalid += 1
            return self.warning
        self.error_id = ErrorCode.NO_ERROR
        first = self.count == 0
        self.count, self.mean, self._scale, self._q = welford_scaled_update(
            self.count, self.mean, self._scale, self._q, dt
        )
        self.min = dt if first else min(self.min, dt)
        self.max = dt if first else max(self.max, dt)
        self.jitter_max = max(self.jitter_max, abs(dt - self._ts))
        warning, alarm = dt > self._warn, dt > self._alarm
        self.overruns += warning
        self.alarms += alarm
        self._flag(warning, alarm)
        self.out = dt
        return self.warning
