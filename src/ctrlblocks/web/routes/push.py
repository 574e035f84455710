"""The WebSocket push ``/ws``: what changed, of the loops on screen, every push period.

Protocol (JSON text frames):

* server -> client, once: ``{"type": "hello", "name", "loops": [names],
  "push_period", "words": {code: [severity, words]}}`` (the state words,
  :data:`ctrlblocks.runtime.status.WORDS`);
* client -> server, whenever the screen changes: ``{"type": "watch", "rows":
  [names], "plate": name or null}`` -- the loops whose table rows are visible,
  and the loop whose faceplate is open (its whole state and its trend samples);
* server -> client, every ``push_period``: ``{"type": "update", "t", "loops":
  {name: {field: value, ...}}, "samples": {name: columns}}`` -- for each watched
  loop only the fields that changed since the last push to this client (all
  of them the first time), and the trend samples not yet sent.

A client that never sends ``watch`` (a script) gets every loop's whole state
and samples.  The views are shared between clients and made at most once per
push period (:class:`~ctrlblocks.web.live.LiveHub`), so a browser watching a
few rows and one faceplate costs the runtime a few rows, not all its loops.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from typing import Any
from urllib.parse import urlsplit

from fastapi import APIRouter, WebSocket
from starlette.websockets import WebSocketDisconnect

from ...runtime.status import WORDS
from ..context import COOKIE
from . import faceplate

__all__ = ["MAX_WATCH", "router"]

router = APIRouter()

MAX_WATCH = 500
"""Most loop names a watch message may list (longer lists are cut)."""


def _same_origin(websocket: WebSocket) -> bool:
    """A browser sends its page's Origin: it must be this server (no cross-site socket)."""
    origin = websocket.headers.get("origin")
    return origin is None or urlsplit(origin).netloc == websocket.headers.get("host")


class _Client:
    """What one socket watches and what it has been sent."""

    def __init__(self, names: list[str]) -> None:
        self.names = names
        self.rows: list[str] | None = None  # None: no watch message yet (every loop, whole)
        self.plate: str | None = None
        self.sent: dict[str, dict[str, Any]] = {}
        self.cursor: dict[str, int] = {}

    def watch(self, msg: Any) -> None:
        if not isinstance(msg, dict) or msg.get("type") != "watch":
            return
        known = set(self.names)
        rows = msg.get("rows")
        if isinstance(rows, list):
            self.rows = [n for n in rows[:MAX_WATCH] if isinstance(n, str) and n in known]
        plate = msg.get("plate")
        self.plate = plate if isinstance(plate, str) and plate in known else None
        if self.plate is not None and self.plate not in self.cursor:
            self.cursor[self.plate] = 0  # its whole trend buffer, once

    def update(self, hub: Any) -> dict[str, Any]:
        """This push's message: the changed fields of the watched loops, the new samples."""
        views: dict[str, dict[str, Any]] = {}
        if self.rows is None:
            for n in self.names:
                views[n] = hub.state(n, fresh=False)
        else:
            for n in self.rows:
                views[n] = hub.row(n)
            if self.plate is not None:
                views[self.plate] = hub.state(self.plate, fresh=False)
        loops: dict[str, dict[str, Any]] = {}
        for n, view in views.items():
            last = self.sent.setdefault(n, {})
            diff = {k: v for k, v in view.items() if k not in last or last[k] != v}
            if diff:
                last.update(diff)
                loops[n] = diff
        for n in list(self.sent):  # a loop no longer watched: sent again whole later
            if n not in views:
                del self.sent[n]
        if self.rows is None:
            samples = hub.since(self.cursor)
        elif self.plate is not None:
            samples = hub.since(self.cursor, (self.plate,))
        else:
            samples = {}
        return {"type": "update", "t": time.time(), "loops": loops, "samples": samples}


@router.websocket("/ws")
async def ws(websocket: WebSocket) -> None:
    fp = faceplate(websocket)
    if not _same_origin(websocket) or not fp.may_view(websocket):
        await websocket.close(code=1008)
        return
    token = websocket.cookies.get(COOKIE)
    await websocket.accept()
    names = fp.runtime.loop_names()
    client = _Client(names)
    client.cursor = fp.hub.cursor()

    async def sender() -> None:
        hello = {"type": "hello", "name": fp.runtime.config.name, "loops": names,
                 "push_period": fp.push_period, "words": WORDS}  # fmt: skip
        await websocket.send_text(json.dumps(hello))
        while True:
            fp.check_users()
            if not fp.public_view and fp.sessions.get(token) is None:
                await websocket.close(code=1008)  # logged out, revoked or expired
                return
            msg = client.update(fp.hub)
            await websocket.send_text(json.dumps(msg, allow_nan=False))
            await asyncio.sleep(fp.push_period)

    async def reader() -> None:
        while True:
            m = await websocket.receive()
            if m["type"] == "websocket.disconnect":
                return
            text = m.get("text")
            if text is not None and len(text) <= 64 * 1024:
                with contextlib.suppress(ValueError, RecursionError):
                    client.watch(json.loads(text))

    tasks = [asyncio.create_task(sender()), asyncio.create_task(reader())]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for t in tasks:
            t.cancel()
        for t in tasks:
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, Exception):
                await t
