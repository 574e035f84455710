"""The live assessment: a sliding window of a running loop, assessed every so often.

:class:`LiveAssessor` keeps the last ``window`` seconds of a loop's samples in
preallocated ring buffers (``append`` is O(1): six array writes per cycle) and
runs :func:`.assess.assess` on the window when :meth:`LiveAssessor.due` says so
(every ``every`` seconds of the loop's own time); the runtime calls it from its
cycle or from a worker.  The model-drift re-identification (seconds of CPU) is
off unless ``drift=True``.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .assess import Assessment, AssessOptions, LoopData, assess

__all__ = ["LiveAssessor"]


class LiveAssessor:
    """Sliding-window assessment of one loop (see the module docstring).

    Parameters
    ----------
    name : str
        The loop's name.
    ts : float
        The loop's sample time [s].
    window : float
        Length of the window [s] (default one hour).
    every : float
        Assess every this many seconds of loop time (default 15 min).
    options : AssessOptions, optional
        As for :func:`.assess.assess`.
    drift : bool
        Also re-identify the model at set-point steps (costly).
    sample : float
        The window keeps one cycle in ``round(sample / ts)`` (default: one a
        second, as a loop monitor samples; the assessment's cost is per kept
        sample).
    """

    def __init__(
        self,
        name: str,
        ts: float,
        *,
        window: float = 3600.0,
        every: float = 900.0,
        options: AssessOptions | None = None,
        drift: bool = False,
        sample: float = 1.0,
    ) -> None:
        if not (math.isfinite(ts) and ts > 0 and math.isfinite(window) and window >= 10 * ts):
            raise ValueError("needs ts > 0 and a window of at least 10 samples")
        self.name = name
        self.every = float(every)
        self._keep = max(1, round(sample / ts))
        self._skip = 0
        n = math.ceil(window / (ts * self._keep))
        self._t = np.zeros(n)
        self._sp = np.zeros(n)
        self._y = np.zeros(n)
        self._u = np.zeros(n)
        self._auto = np.zeros(n, dtype=bool)
        self._ok = np.zeros(n, dtype=bool)
        self._i = 0
        self._full = False
        self._next = -math.inf
        self._first_delay = 0.0
        opts = options or AssessOptions()
        self.options = opts if drift else dataclasses.replace(opts, drift_segments=0)
        self.last: Assessment | None = None

    @property
    def capacity(self) -> int:
        """Samples the window holds."""
        return int(self._t.size)

    @property
    def keep(self) -> int:
        """One cycle in ``keep`` is kept."""
        return self._keep

    def delay_first(self, seconds: float) -> None:
        """Make the first assessment due ``seconds`` after the first sample (spreads many loops)."""
        self._first_delay = float(seconds)

    def append(self, t: float, sp: float, pv: float, mv: float, auto: bool, pv_ok: bool) -> None:
        """Record one cycle (time [s], setpoint, PV, MV, in AUTO, PV valid)."""
        if self._next == -math.inf:
            self._next = t + self._first_delay
        if self._skip:
            self._skip -= 1
            return
        self._skip = self._keep - 1
        i = self._i
        self._t[i] = t
        self._sp[i] = sp
        self._y[i] = pv
        self._u[i] = mv
        self._auto[i] = auto
        self._ok[i] = pv_ok
        i += 1
        if i == self._t.size:
            i = 0
            self._full = True
        self._i = i

    def due(self, t: float) -> bool:
        """True when an assessment is due at loop time ``t``."""
        return t >= self._next and (self._full or self._i >= 10)

    def window(self) -> LoopData:
        """The samples of the window, oldest first."""
        k = np.r_[self._i : self._t.size, 0 : self._i] if self._full else np.arange(self._i)
        mode = np.where(self._auto[k], "AUTO", "MANUAL").tolist()
        return LoopData(
            self._t[k], self._sp[k], self._y[k], self._u[k], mode, self._ok[k], self.name
        )

    def assess(self, t: float | None = None) -> Assessment | None:
        """Assess the window now; None while it holds fewer than 10 samples."""
        if not (self._full or self._i >= 10):
            return None
        data = self.window()
        if not np.all(np.diff(data.t) > 0):
            return self.last  # a time that went backwards (a restart): wait for a clean window
        self.last = assess(data, self.options)
        self._next = (data.t[-1] if t is None else t) + self.every
        return self.last

    @staticmethod
    def benchmark(loops: int = 200, ts: float = 0.1, rounds: int = 5) -> dict[str, float]:
        """CPU cost of the live assessment of ``loops`` loops at ``ts``, per second of operation.

        Measured: ``append`` per loop and cycle, and one assessment of a full
        window (the defaults: one hour, every 15 min); against the PID block's
        call per loop and cycle, the least a runtime cycle of a loop costs.
        Medians over ``rounds``.
        """
        from ..blocks.pid import PID

        rng = np.random.default_rng(0)
        a = LiveAssessor("bench", ts)
        n = a.capacity * a.keep
        y = (50.0 + rng.normal(0.0, 0.5, n)).tolist()
        pid = PID(kp=1.0, ti=10.0, ts=ts, u_min=0.0, u_max=100.0)
        app, ass, blk = [], [], []
        for _ in range(rounds):
            c0 = time.process_time()
            for k in range(n):
                a.append(k * ts, 50.0, y[k], 50.0, True, True)
            app.append((time.process_time() - c0) / n)
            c0 = time.process_time()
            a.assess()
            ass.append(time.process_time() - c0)
            c0 = time.process_time()
            for k in range(n):
                pid(50.0, y[k])
            blk.append((time.process_time() - c0) / n)
        t_app, t_ass, t_blk = (float(np.median(x)) for x in (app, ass, blk))
        live = loops * (t_app / ts + t_ass / a.every)
        blocks = loops * t_blk / ts
        return {
            "loops": loops,
            "ts": ts,
            "window_samples": a.capacity,
            "every_s": a.every,
            "append_us": 1e6 * t_app,
            "assess_window_ms": 1e3 * t_ass,
            "pid_call_us": 1e6 * t_blk,
            "live_cpu_per_s": live,
            "blocks_cpu_per_s": blocks,
            "live_over_blocks": live / blocks,
        }
