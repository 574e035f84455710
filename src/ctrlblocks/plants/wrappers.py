"""Measurement noise, sensor, actuator and load disturbances, as wrappers that are plants.

A real loop sees the process through an actuator and a sensor.  Each is a
:class:`~.base.Plant` that wraps another plant, so they compose::

    plant = Sensor(Actuator(ThreeTank(), u_min=0.0, u_max=5.0, rate=2.0),
                   noise=Noise(0.005, kind="gaussian", seed=1), y_max=1.9)

and the simulator drives the outermost one like any plant.  Signal flow of one
sample (``process`` builds exactly this chain)::

    u_cmd --(+ load_in)--> rate limit --> [u_min, u_max] --> plant --> y_plant
    y_plant --(+ load_out)--> y_true --(+ noise)--> [y_min, y_max] --> y

Run-time changes (the simulator's events) are plain attribute writes:
``actuator.load``, ``sensor.load`` (load disturbances at the input and the
output), ``actuator.rate``, ``actuator.set_limits(lo, hi)``,
``sensor.set_range(lo, hi)``, ``sensor.fault``; an inner model is reached with
``chain.find(Type)``.

Sources
-------
* Noise: controltheplant 2024, ``NoiseGenerator`` (section 1.3): "white noise is simulated
  as a sequence of random numbers within a specified range" -- ``kind="uniform"``,
  uniform in ``[-level, level]``.  ``kind="gaussian"`` (standard deviation
  ``level``) is ctrlblocks' addition.  Coloured noise is white noise through a
  first-order filter with correlation time ``t_corr``:

      n[k+1] = a n[k] + sqrt(1 - a^2) w[k],   a = exp(-ts / t_corr)      (N1)

  whose stationary variance equals that of ``w`` (so ``level`` keeps its
  meaning) and whose autocorrelation is ``a^|j|`` (the sampled
  Ornstein-Uhlenbeck process).  The first value is ``n[0] = w[0]``, a draw from
  the stationary distribution.  Numbers come from a seeded
  :class:`numpy.random.Generator` (PCG64), drawn in blocks; the sequence for
  a seed is the one ``default_rng(seed).uniform(-level, level, N)`` (or
  ``.normal(0, level, N)``) gives.
* Sensor saturation: ``y_max`` is ``Y_sat`` of Nowak et al. 2018, section 4.3 (derivative
  backoff, Fig. 1: ``Y_sat = 1.9``).
* Input load: Nowak et al. 2018, section 6: "the load disturbance emulated by adding
  Delta p_s directly to the manipulating variable" -- added to the command
  before the actuator's limits (the valve cannot exceed its range).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..blocks.base import (
    ErrorCode,
    ParameterError,
    require_choice,
    require_finite,
    require_limits,
    require_nonnegative,
    require_positive,
)
from ..blocks.signals import clamp
from .base import _P, Plant

__all__ = ["Actuator", "Noise", "Sensor", "process"]

_CHUNK = 256
MAX_NOISE = 1e300
"""Largest noise level: ``uniform(-level, level)`` needs ``2 level`` finite; far beyond any
measurement, far below the overflow."""


class Noise:
    """Seeded white or coloured noise (controltheplant 2024, ``NoiseGenerator``; (N1) for coloured).

    Parameters
    ----------
    level : float
        ``kind="uniform"``: half-width of the range ``[-level, level]``;
        ``kind="gaussian"``: standard deviation.  Output units, 0 ... ``MAX_NOISE``.
    kind : {"uniform", "gaussian"}
        Distribution of the white sequence.
    t_corr : float
        Correlation time [s] of the first-order filter (N1); 0 (default) gives
        white noise.
    ts : float, optional
        Sample time [s]; required when ``t_corr > 0``.
    seed : int or None
        Seed of the generator; None draws a fresh seed (not reproducible).

    Examples
    --------
    >>> n = Noise(0.1, seed=3)
    >>> a = [n.sample() for _ in range(3)]
    >>> n.reset()
    >>> a == [n.sample() for _ in range(3)]
    True
    """

    def __init__(
        self,
        level: float,
        *,
        kind: str = "uniform",
        t_corr: float = 0.0,
        ts: float | None = None,
        seed: int | None = 0,
    ) -> None:
        self.level = require_nonnegative("level", level)
        if self.level > MAX_NOISE:  # the generator's range 2 level overflows (1e308)
            raise ParameterError(ErrorCode.BAD_PARAMETER, "level",
                                 f"must be at most {MAX_NOISE:.3g}, got {level!r}")  # fmt: skip
        self.kind = require_choice("kind", kind, ("uniform", "gaussian"))
        self.t_corr = require_nonnegative("t_corr", t_corr, ErrorCode.BAD_TIME_CONSTANT)
        if self.t_corr > 0.0:
            if ts is None:
                raise ParameterError(ErrorCode.NO_CYCLE, "ts", "coloured noise needs ts")
            self.ts: float | None = require_positive("ts", ts, ErrorCode.NO_CYCLE)
            self.a = math.exp(-self.ts / self.t_corr)
        else:
            self.ts = None if ts is None else require_positive("ts", ts, ErrorCode.NO_CYCLE)
            self.a = 0.0
        self.b = math.sqrt(1.0 - self.a * self.a)
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (2**63))
        self.seed = int(seed)
        self.reset()

    def reset(self) -> None:
        """Restart the sequence from the seed."""
        self._rng = np.random.default_rng(self.seed)
        self._buf: list[float] = []
        self._i = 0
        self._x: float | None = None

    def _white(self) -> float:
        if self._i >= len(self._buf):
            if self.kind == "uniform":
                arr = self._rng.uniform(-self.level, self.level, _CHUNK)
            else:
                arr = self._rng.normal(0.0, self.level, _CHUNK)
            self._buf = arr.tolist()
            self._i = 0
        w = self._buf[self._i]
        self._i += 1
        return w

    def sample(self) -> float:
        """The next noise value."""
        w = self._white()
        if self.a == 0.0:
            return w
        x = w if self._x is None else self.a * self._x + self.b * w
        self._x = x
        return x

    def samples(self, m: int) -> np.ndarray:
        """The next ``m`` noise values at once: what ``m`` calls of :meth:`sample` return.

        The white values are what the chunks of :meth:`sample` hold, drawn in
        one call of the generator (numpy's generators give the same stream
        for one call of ``k * 256`` values as for ``k`` calls of 256; the
        tests check it), so the sequence and the state afterwards are the
        same to the bit.
        """
        head = np.array(self._buf[self._i : self._i + m], dtype=float)
        self._i += head.shape[0]
        need = m - head.shape[0]
        if need <= 0:
            w = head
        else:
            chunks = -(-need // _CHUNK)
            if self.kind == "uniform":
                arr = self._rng.uniform(-self.level, self.level, chunks * _CHUNK)
            else:
                arr = self._rng.normal(0.0, self.level, chunks * _CHUNK)
            self._buf = arr[(chunks - 1) * _CHUNK :].tolist()
            self._i = need - (chunks - 1) * _CHUNK
            w = np.concatenate((head, arr[:need]))
        if self.a == 0.0:
            return w
        x = self._x
        for j, wj in enumerate(w.tolist()):
            x = wj if x is None else self.a * x + self.b * wj
            w[j] = x
        self._x = x
        return w

    def snapshot(self) -> dict[str, Any]:
        """A copy of the generator state (restore continues the same sequence)."""
        return {
            "rng": self._rng.bit_generator.state,
            "buf": list(self._buf),
            "i": self._i,
            "x": self._x,
        }

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        self._rng.bit_generator.state = snap["rng"]
        self._buf = list(snap["buf"])
        self._i = int(snap["i"])
        self._x = snap["x"]

    def __repr__(self) -> str:
        col = f", t_corr={self.t_corr!r}, ts={self.ts!r}" if self.a else ""
        return f"Noise({self.level!r}, kind={self.kind!r}{col}, seed={self.seed!r})"


class _Wrapper(Plant):
    """A plant around another plant (``inner``); ``ts`` is the inner one's."""

    def __init__(self, plant: Plant) -> None:
        if not isinstance(plant, Plant):
            raise TypeError(f"{type(self).__name__} wraps a Plant, got {type(plant).__name__}")
        self.inner = plant
        self.ts = plant.ts

    def find(self, cls: type[_P]) -> _P | None:
        """This wrapper if it is a ``cls``, else the first ``cls`` inside."""
        if isinstance(self, cls):
            return self
        return self.inner.find(cls)


class Actuator(_Wrapper):
    """Actuator: input load, rate limit and range limits in front of a plant.

    The applied input of a sample is ::

        v = clamp(clamp(u_cmd + load, u_prev - rate ts, u_prev + rate ts), u_min, u_max)

    with ``u_prev`` the input applied in the previous sample.  A non-finite
    command holds the previous command.

    Parameters
    ----------
    plant : Plant
        The process.
    u_min, u_max : float
        Range of the applied input [input units]; infinite: no limit.
    rate : float
        Largest rate of change [input units / s], >= 0; inf (default): none.
    load : float
        Input load disturbance added to the command [input units].

    Attributes
    ----------
    load : float
        Settable at any time (e.g. a load step event).
    u : float
        Input applied to the plant in the last sample.
    u_cmd : float
        Last command received.
    limited : bool
        True when the last applied input differed from ``u_cmd + load``.
    """

    def __init__(
        self,
        plant: Plant,
        *,
        u_min: float = -math.inf,
        u_max: float = math.inf,
        rate: float = math.inf,
        load: float = 0.0,
    ) -> None:
        super().__init__(plant)
        self.set_limits(u_min, u_max)
        self.rate = rate
        self.load = require_finite("load", load)
        self.reset(0.0)

    @property
    def rate(self) -> float:
        """Rate limit [input units / s]; ``inf`` for none.  Settable (>= 0)."""
        return self._rate

    @rate.setter
    def rate(self, value: float) -> None:
        v = float(value)
        if math.isnan(v) or v < 0.0:
            raise ParameterError(ErrorCode.BAD_RATE, "rate", f"must be >= 0, got {value!r}")
        self._rate = v
        self._du = v * self.ts

    @property
    def u_min(self) -> float:
        """Lower limit of the applied input (change with :meth:`set_limits`)."""
        return self._lo

    @property
    def u_max(self) -> float:
        """Upper limit of the applied input (change with :meth:`set_limits`)."""
        return self._hi

    def set_limits(self, u_min: float, u_max: float) -> None:
        """Set the range; a reversed or NaN pair raises ``BAD_LIMITS`` and keeps the old one."""
        self._lo, self._hi = require_limits("u_min", u_min, "u_max", u_max)

    @property
    def y(self) -> float:
        """The plant's output."""
        return self.inner.y

    def _shape(self, u: float) -> float:
        v = u + self.load
        du = self._du
        if du < math.inf:
            v = clamp(v, self.u - du, self.u + du)
        return clamp(v, self._lo, self._hi)

    def step(self, u: float) -> float:
        """Shape the command and apply it to the plant for one sample."""
        if not math.isfinite(u):
            u = self.u_cmd
        self.u_cmd = float(u)
        v = self._shape(self.u_cmd)
        self.limited = v != self.u_cmd + self.load
        self.u = v
        return self.inner.step(v)

    def reset(self, u0: float = 0.0) -> None:
        """Steady state for the constant command ``u0`` (applied: ``u0 + load`` clamped)."""
        u0 = float(u0) if math.isfinite(u0) else 0.0
        self.u_cmd = u0
        self.u = clamp(u0 + self.load, self._lo, self._hi)
        self.limited = self.u != u0 + self.load
        self.inner.reset(self.u)

    def snapshot(self) -> dict[str, Any]:
        """Own state plus the inner plant's."""
        return {"u": self.u, "u_cmd": self.u_cmd, "inner": self.inner.snapshot()}

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        self.u, self.u_cmd = float(snap["u"]), float(snap["u_cmd"])
        self.inner.restore(snap["inner"])

    def __repr__(self) -> str:
        return (
            f"Actuator({self.inner!r}, u_min={self._lo!r}, u_max={self._hi!r}, "
            f"rate={self._rate!r}, load={self.load!r})"
        )


class Sensor(_Wrapper):
    """Sensor: output load, measurement noise and sensor saturation after a plant.

    ::

        y_true = plant.y + load
        y      = clamp(y_true + n[k], y_min, y_max)      (or ``fault`` when set)

    The noise value ``n[k]`` is drawn once per sample (at ``step`` and at
    ``reset``), so reading ``y`` twice gives the same number; ``load``,
    ``y_min``/``y_max`` and ``fault`` act on ``y`` at once when changed.

    Parameters
    ----------
    plant : Plant
        The process (or an :class:`Actuator` around it).
    noise : Noise, optional
        Measurement noise added to the output.
    y_min, y_max : float
        Measuring range of the sensor: the output saturates there (``y_max``
        is ``Y_sat`` of Nowak et al. 2018, section 4.3).
    load : float
        Output load disturbance [output units], settable at any time.

    Attributes
    ----------
    fault : float or None
        When not None, ``y`` returns this value (e.g. ``math.nan``: a broken
        sensor); set it back to None to recover.
    """

    def __init__(
        self,
        plant: Plant,
        *,
        noise: Noise | None = None,
        y_min: float = -math.inf,
        y_max: float = math.inf,
        load: float = 0.0,
    ) -> None:
        super().__init__(plant)
        if noise is not None and not isinstance(noise, Noise):
            raise TypeError("noise must be a Noise")
        self.noise = noise
        self.set_range(y_min, y_max)
        self.load = require_finite("load", load)
        self.fault: float | None = None
        self.reset(0.0)

    @property
    def y_min(self) -> float:
        """Lower end of the measuring range (change with :meth:`set_range`)."""
        return self._lo

    @property
    def y_max(self) -> float:
        """Upper end of the measuring range (sensor saturation ``Y_sat``)."""
        return self._hi

    def set_range(self, y_min: float, y_max: float) -> None:
        """Set the measuring range; a reversed or NaN pair raises ``BAD_LIMITS``."""
        self._lo, self._hi = require_limits("y_min", y_min, "y_max", y_max)

    @property
    def u(self) -> float:  # type: ignore[override]
        """Input applied to the inner plant in the last sample."""
        return self.inner.u

    @property
    def y_true(self) -> float:
        """Process output with the output load, before noise and saturation."""
        return self.inner.y + self.load

    @property
    def noise_value(self) -> float:
        """The noise value of this sample."""
        return self._n

    @property
    def saturated(self) -> bool:
        """True when the sensor is at an end of its range."""
        v = self.inner.y + self.load + self._n
        return v >= self._hi or v <= self._lo

    @property
    def y(self) -> float:
        """The measurement."""
        if self.fault is not None:
            return self.fault
        return clamp(self.inner.y + self.load + self._n, self._lo, self._hi)

    def step(self, u: float) -> float:
        """Advance the plant; draw the next noise value; return the measurement."""
        self.inner.step(u)
        self._n = self.noise.sample() if self.noise is not None else 0.0
        return self.y

    def reset(self, u0: float = 0.0) -> None:
        """Reset the plant to the steady state for ``u0``; draw a noise value.

        The noise sequence is *not* restarted (call ``noise.reset()`` for that).
        """
        self.inner.reset(u0)
        self._n = self.noise.sample() if self.noise is not None else 0.0

    def snapshot(self) -> dict[str, Any]:
        """Own state (noise generator included) plus the inner plant's."""
        return {
            "n": self._n,
            "noise": self.noise.snapshot() if self.noise is not None else None,
            "inner": self.inner.snapshot(),
        }

    def restore(self, snap: dict[str, Any]) -> None:
        """Put back a state taken by :meth:`snapshot`."""
        self._n = float(snap["n"])
        if self.noise is not None:
            self.noise.restore(snap["noise"])
        self.inner.restore(snap["inner"])

    def __repr__(self) -> str:
        return (
            f"Sensor({self.inner!r}, noise={self.noise!r}, y_min={self._lo!r}, "
            f"y_max={self._hi!r}, load={self.load!r})"
        )


def process(
    plant: Plant,
    *,
    u_min: float = -math.inf,
    u_max: float = math.inf,
    rate: float = math.inf,
    load_in: float = 0.0,
    noise: Noise | None = None,
    y_min: float = -math.inf,
    y_max: float = math.inf,
    load_out: float = 0.0,
) -> Sensor:
    """``Sensor(Actuator(plant, ...), ...)``: the whole chain of the module docstring.

    Reach the parts with ``chain.find(Actuator)``, ``chain`` (the sensor) and
    ``chain.find(type(plant))``.
    """
    act = Actuator(plant, u_min=u_min, u_max=u_max, rate=rate, load=load_in)
    return Sensor(act, noise=noise, y_min=y_min, y_max=y_max, load=load_out)
