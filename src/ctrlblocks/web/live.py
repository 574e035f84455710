"""Live data for the faceplate: a ring buffer of recent samples per loop, and the loop states.

The :class:`LiveHub` is hooked into the runtime's ``on_sample`` callback (it
keeps a callback that was already there and calls it first).  Every sample of
every loop goes into the loop's ring buffer (the last ``seconds`` of the
trend); each WebSocket client keeps a cursor per loop and gets, at every push,
the samples it has not seen yet (so a 20 Hz loop shows every one of its
samples, whatever the push period).

What a push costs the runtime: a loop's view -- its table row
(:data:`ROW_FIELDS`, :meth:`LiveHub.row`) or its whole state
(:meth:`LiveHub.state`) -- is made at most once per push period, whoever asks,
and only for the loops some client watches (:mod:`ctrlblocks.web.routes.push`:
the rows on screen and the selected loop); each client is sent only the
fields that changed since its last push.

Everything sent is plain JSON: NaN and infinities become ``null``
(:func:`json_safe`), because JSON has no NaN.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["ROW_FIELDS", "LiveHub", "alarms", "json_safe"]

ROW_FIELDS = ("name", "block", "mode", "sp", "pv", "mv", "status", "conditions")
"""What a loop's row in the loop table shows (its state words: ``status``, with the
texts in ``conditions``, :mod:`ctrlblocks.runtime.status`)."""

SAMPLE_FIELDS = ("seq", "t", "sp", "pv", "mv", "manual", "error_id")
"""Columns of a trend batch: a sequence number per loop, wall-clock time [s since
the epoch], SP, PV, MV, 1 when the loop was in MAN, the block's error code."""


def json_safe(x: Any) -> Any:
    """``x`` with every non-finite float replaced by None (recursively), tuples as lists."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if x is None or isinstance(x, (bool, int, str)):
        return x
    if hasattr(x, "item"):  # numpy scalar
        return json_safe(x.item())
    return str(x)


def _tuning_value(v: Any) -> Any:
    """A tuning for JSON: infinities as the strings "inf"/"-inf" (the page shows and sends them)."""
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def alarms(state: dict[str, Any]) -> list[str]:
    """The texts of the loop's conditions of severity alarm and warning (empty: all is well).

    The conditions themselves (code, severity, words) are the state's ``status``
    and ``conditions`` (:mod:`ctrlblocks.runtime.status`).
    """
    return [c["text"] for c in state.get("conditions") or () if c["severity"] != "info"]


class LiveHub:
    """Recent samples of every loop of a runtime, for the live trends.

    Parameters
    ----------
    runtime : Runtime
        The runtime (``loop_names``, ``states``, ``on_sample``).
    seconds : float
        Length of the trend buffer [s] (per loop, at its sample time).
    """

    def __init__(
        self,
        runtime: Any,
        seconds: float = 300.0,
        period: float = 0.1,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.runtime = runtime
        self.seconds = float(seconds)
        self.period = float(period)  # a view is made at most once per period
        self.clock = clock
        self._rows: dict[str, tuple[float, dict[str, Any]]] = {}
        self._states: dict[str, tuple[float, dict[str, Any]]] = {}
        self.made = 0  # views made (a benchmark counts them)
        self._lock = threading.Lock()
        self._buf: dict[str, collections.deque[tuple[Any, ...]]] = {}
        self._seq: dict[str, int] = {}
        for name in runtime.loop_names():
            ts = runtime.loops[name].ts
            self._buf[name] = collections.deque(maxlen=max(10, int(self.seconds / ts) + 1))
            self._seq[name] = 0
        self._chained = runtime.on_sample
        runtime.on_sample = self.on_sample

    def detach(self) -> None:
        """Give the runtime its previous ``on_sample`` back."""
        if self.runtime.on_sample == self.on_sample:
            self.runtime.on_sample = self._chained

    def on_sample(self, s: Any) -> None:
        """Runtime callback: keep the sample (and call a callback that was there before)."""
        if self._chained is not None:
            self._chained(s)
        with self._lock:
            buf = self._buf.get(s.loop)
            if buf is None:
                return
            self._seq[s.loop] += 1
            buf.append(
                (
                    self._seq[s.loop],
                    s.t_wall,
                    s.sp,
                    s.pv,
                    s.mv,
                    1 if s.mode == "manual" else 0,
                    s.error_id,
                )
            )

    def cursor(self) -> dict[str, int]:
        """A cursor that has seen nothing yet (the next :meth:`since` sends the whole buffer)."""
        return dict.fromkeys(self._buf, 0)

    def since(
        self, cursor: dict[str, int], names: Iterable[str] | None = None
    ) -> dict[str, dict[str, list[Any]]]:
        """Samples newer than ``cursor`` of the loops ``names`` (default all), as columns.

        Advances ``cursor`` in place.
        """
        out: dict[str, dict[str, list[Any]]] = {}
        with self._lock:
            for name in self._buf if names is None else names:
                buf = self._buf.get(name)
                if buf is None:
                    continue
                last = cursor.get(name, 0)
                if not buf or buf[-1][0] <= last:
                    continue
                rows = []
                for r in reversed(buf):  # newest first, stop at what the client has
                    if r[0] <= last:
                        break
                    rows.append(r)
                rows.reverse()
                cursor[name] = rows[-1][0]
                out[name] = {
                    f: [json_safe(r[i]) for r in rows] for i, f in enumerate(SAMPLE_FIELDS)
                }
        return out

    def states(self) -> list[dict[str, Any]]:
        """Every loop's :meth:`state`."""
        return [self.state(n) for n in self.runtime.loop_names()]

    def state(self, loop: str, *, fresh: bool = True) -> dict[str, Any]:
        """The runtime's ``state`` of ``loop`` with its ``alarms``, JSON-safe.

        ``fresh`` False: one made within the last push period will do (the push).
        """
        return self._cached(self._states, loop, fresh, lambda: _view(self.runtime.state(loop)))

    def row(self, loop: str) -> dict[str, Any]:
        """The loop's table row (:data:`ROW_FIELDS`), made at most once per push period."""

        def make() -> dict[str, Any]:
            lp = self.runtime.loops[loop]
            return json_safe({
                "name": loop,
                "block": lp.config.block_type,
                "mode": lp.mode,
                "sp": lp.sp,
                "pv": lp.pv,
                "mv": lp.mv,
                "status": lp.conditions.codes(),
                "conditions": lp.conditions.as_json(),
            })  # fmt: skip

        return self._cached(self._rows, loop, False, make)

    def _cached(self, cache: dict[str, Any], loop: str, fresh: bool, make: Any) -> dict[str, Any]:
        now = self.clock()
        hit = cache.get(loop)
        if hit is not None and not fresh and now - hit[0] < 0.5 * self.period:
            return hit[1]  # type: ignore[no-any-return]
        view = make()
        self.made += 1
        cache[loop] = (now, view)
        return view


def _view(state: dict[str, Any]) -> dict[str, Any]:
    """A loop state for the page: ``alarms`` added, tunings and non-finite floats JSON-safe."""
    st = dict(state)
    st["alarms"] = alarms(st)
    st["tunings"] = {k: _tuning_value(v) for k, v in st.get("tunings", {}).items()}
    return json_safe(st)
