"""The page and the read-only API: info, loop states, history (JSON and CSV), audit trail."""

from __future__ import annotations

import asyncio
import contextlib
import csv
import io
import json
import math
from collections.abc import Mapping
from importlib import resources
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, JSONResponse, Response

from ..auth import PERMISSIONS
from ..context import HISTORY_COLUMNS
from ..live import json_safe
from . import faceplate

__all__ = ["csv_header", "router"]

router = APIRouter()

STATIC = resources.files("ctrlblocks.web") / "static"


def csv_header(units: Mapping[str, str]) -> list[str]:
    """The CSV download's header: :data:`HISTORY_COLUMNS` with units, ``sp [bar]``, ``t [s]``."""
    with_unit = {
        "t_wall": "s",
        "t": "s",
        "dt": "s",
        **{k: units.get(k, "") for k in ("sp", "pv", "mv")},
    }
    return [f"{c} [{with_unit[c]}]" if with_unit.get(c) else c for c in HISTORY_COLUMNS]


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return FileResponse(str(STATIC / "index.html"), media_type="text/html")


@router.get("/favicon.ico", include_in_schema=False)
async def favicon() -> Response:
    return Response(status_code=204)


@router.get("/api/info")
async def info(request: Request) -> dict[str, Any]:
    fp = faceplate(request)
    s = fp.session_of(request)
    role = None if s is None else s.role
    out: dict[str, Any] = {
        "name": fp.runtime.config.name,
        "user": None if s is None else s.user,
        "role": role,
        "may_change": sorted(PERMISSIONS.get(role or "", ())),
        "public_view": fp.public_view,
        "may_view": fp.public_view or s is not None,
        "push_period": fp.push_period,
        "trend_seconds": fp.trend_seconds,
        "historian": fp.runtime.historian is not None,
    }
    if out["may_view"]:
        out["loops"] = fp.runtime.loop_names()
        out["engineering"] = {n: b.as_json() for n, b in fp.bounds.items()}
    return out


@router.get("/api/loops", response_model=None)
async def loops(request: Request) -> Any:
    fp = faceplate(request)
    if not fp.may_view(request):
        return fp.not_logged_in()
    return fp.hub.states()


@router.get("/api/loops/{name}", response_model=None)
async def one_loop(name: str, request: Request) -> Any:
    fp = faceplate(request)
    if not fp.may_view(request):
        return fp.not_logged_in()
    try:
        return fp.loop_state(name)
    except KeyError:
        return fp.unknown_loop(name)


async def _history(request: Request, name: str, start: float | None, end: float | None) -> Any:
    """The loop's historian rows for a logged-in user, or the refusal (login, loop, window)."""
    fp = faceplate(request)
    if fp.session_of(request) is None:
        return fp.not_logged_in()
    if name not in fp.runtime.loop_names():
        return fp.unknown_loop(name)
    return await fp.history_rows(name, start, end)


@router.get("/api/loops/{name}/history", response_model=None)
async def history(
    request: Request,
    name: str,
    start: float | None = None,
    end: float | None = None,
    max_points: int = 5000,
) -> Any:
    fp = faceplate(request)
    rows = await _history(request, name, start, end)
    if isinstance(rows, JSONResponse):
        return rows
    n = len(rows)
    stride = max(1, math.ceil(n / max(1, max_points)))
    cols = {c: [json_safe(r[i]) for r in rows[::stride]] for i, c in enumerate(HISTORY_COLUMNS)}
    return {"loop": name, "rows": n, "stride": stride, "columns": cols,
            "units": fp.bounds[name].units}  # fmt: skip


@router.get("/api/loops/{name}/history.csv", response_model=None)
async def history_csv(
    request: Request, name: str, start: float | None = None, end: float | None = None
) -> Any:
    fp = faceplate(request)
    rows = await _history(request, name, start, end)
    if isinstance(rows, JSONResponse):
        return rows
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(csv_header(fp.bounds[name].units))
    for r in rows:  # NULL (SQLite's NaN) as an empty field
        w.writerow(["" if v is None or (isinstance(v, float) and math.isnan(v)) else v for v in r])
    fname = f"{name}-{int(rows[0][0]) if rows else 0}.csv"
    return Response(
        buf.getvalue(),
        media_type="text/csv",
        headers={"Content-Disposition": f'attachment; filename="{fname}"'},
    )


@router.get("/api/audit", response_model=None)
async def audit_trail(request: Request, limit: int = 50, loop: str | None = None) -> Any:
    fp = faceplate(request)
    if fp.session_of(request) is None:
        return fp.not_logged_in()
    h = fp.historian_or_error()
    if isinstance(h, JSONResponse):
        return h
    rows = await asyncio.to_thread(h.audit_rows, loop, max(1, min(int(limit), 1000)))
    out = []
    for d in reversed(rows):  # newest first
        for k in ("old", "new"):
            with contextlib.suppress(TypeError, ValueError):
                d[k] = json.loads(d[k]) if d[k] is not None else None
        d["ok"] = bool(d["ok"])
        out.append(json_safe(d))
    return out
