"""The faceplate's routes, one module per concern (each an ``APIRouter``).

* :mod:`.pages` -- the page, ``/api/info``, loop states, history, CSV, audit;
* :mod:`.session` -- login and logout;
* :mod:`.commands` -- operator commands and live tuning;
* :mod:`.alarms` -- process alarms: the list, acknowledge, shelve, unshelve;
* :mod:`.push` -- the WebSocket push (only what changed, only the loops on screen).

Every route finds the shared :class:`~ctrlblocks.web.context.Faceplate` as
``request.app.state.faceplate`` (:func:`faceplate`).
"""

from __future__ import annotations

from typing import Any

from fastapi import Request, WebSocket

__all__ = ["faceplate"]


def faceplate(conn: Request | WebSocket) -> Any:
    """The application's :class:`~ctrlblocks.web.context.Faceplate`."""
    return conn.app.state.faceplate
