"""Operator commands and live tuning: checked here (rate, body, login, role), then by the loop.

A command is confirmed (200) only once the runtime has retained it: in the
retain file, fsync'd (:meth:`Runtime.execute <ctrlblocks.runtime.Runtime.execute>`);
a change that is in force but could not be retained is a 503 that says so.
Every refusal leaves a bounded audit row: field names, never values, at most
:data:`~ctrlblocks.web.context.AUDIT_REFUSALS` per client address and window
(the runtime bounds each user's refusals the same way).
"""

from __future__ import annotations

import logging
import sqlite3
from collections.abc import Mapping
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ...blocks.base import ErrorCode, ParameterError
from ...runtime.bounds import LoopBounds
from ...runtime.loop import CommandError
from ..auth import PERMISSIONS
from ..context import article, error
from ..defences import summary
from ..live import json_safe
from . import faceplate

__all__ = ["TUNE_OPTIONS", "coerce_command", "proposal_outside", "router", "tune_options"]

log = logging.getLogger("ctrlblocks.web.app")

router = APIRouter()

TUNE_OPTIONS = ("method", "amplitude", "mv_min", "mv_max", "pv_min", "pv_max", "max_time",
                "hysteresis", "pre_time")  # fmt: skip
"""Keys of a ``POST /api/loops/NAME/tune`` body (:meth:`LiveTuning.start
<ctrlblocks.runtime.autotune.LiveTuning.start>`; ``hysteresis`` empty: sized from the noise)."""


def _to_number(text: str, current: Any) -> Any:
    """Convert input-field ``text`` to the type of ``current`` (see :func:`coerce_command`)."""
    s = text.strip()
    if current is None and s.lower() in ("", "none", "null"):
        return None
    if isinstance(current, bool) or not (
        current is None or isinstance(current, (int, float, list, tuple))
    ):
        return text
    if "," in s and (current is None or isinstance(current, (list, tuple))):
        try:
            return [float(p) for p in s.strip("()[]").split(",")]
        except ValueError:
            return text
    if isinstance(current, int):
        try:
            return int(s)
        except ValueError:
            pass
    try:
        return float(s)
    except ValueError:
        return text


def coerce_command(changes: Mapping[str, Any], state: Mapping[str, Any]) -> dict[str, Any]:
    """A command body with input-field text converted to numbers.

    Text from input fields is accepted for numbers (``"1.5"``, ``"inf"``): a
    string is converted to the type of the value in force (int, float,
    ``None`` for "" when the parameter may be unset); what does not convert
    goes to the block unchanged and the block refuses it with its code.
    """
    out = dict(changes)
    for k in ("sp", "manual_value", "u_min", "u_max"):
        if isinstance(out.get(k), str):
            out[k] = _to_number(out[k], 0.0)
    tun = out.get("tunings")
    if isinstance(tun, Mapping):
        current = state.get("tunings", {})
        out["tunings"] = {
            k: _to_number(v, current.get(k)) if isinstance(v, str) else v for k, v in tun.items()
        }
    return out


def tune_options(body: Mapping[str, Any], bounds: LoopBounds) -> dict[str, Any]:
    """The start options of a tuning body: text to numbers, empty = default, MV range kept.

    The experiment's MV bounds default to the loop's engineering ``mv_range``
    where it is narrower than the output limits, and may not leave it.
    """
    unknown = sorted(str(k)[:32] for k in body if k not in TUNE_OPTIONS)
    if unknown:
        raise CommandError(unknown[0], f"unknown option; options: {', '.join(TUNE_OPTIONS)}")
    out: dict[str, Any] = {}
    for k, v in body.items():
        if k == "method":
            out[k] = v
        elif v is None or (isinstance(v, str) and not v.strip()):
            continue
        else:
            out[k] = _to_number(v, 0.0) if isinstance(v, str) else v
    rng = bounds.mv
    if rng is not None:
        out.setdefault("mv_min", max(rng.lo, float(bounds.block.u_min)))
        out.setdefault("mv_max", min(rng.hi, float(bounds.block.u_max)))
        for k in ("mv_min", "mv_max"):
            x = out[k]
            if isinstance(x, (int, float)) and not isinstance(x, bool):
                why = rng.refuses(float(x))
                if why is not None:
                    raise CommandError(k, why, ErrorCode.BAD_LIMITS)
    return out


def proposal_outside(
    runtime: Any, loop: str, proposal: str, bounds: LoopBounds
) -> tuple[str, str, int] | None:
    """The engineering-range refusal of accepting ``proposal`` (None: inside, or unknown)."""
    from ...runtime.autotune import block_tunings

    st = runtime.tuning.status(loop) or {}
    prop = (st.get("proposals") or {}).get(proposal)
    if prop is None:
        return None  # the runtime refuses it with the list of proposals
    try:
        tunings = block_tunings(runtime.loops[loop], prop)
    except CommandError:
        return None  # the runtime refuses it with the reason
    return bounds.check({"tunings": tunings})


async def _admitted(
    name: str, request: Request, action: str, route: str, who_may: str
) -> tuple[Any, dict[str, Any]] | JSONResponse:
    """(session, body) of a command-like request, or the refusal (rate, loop, body, login).

    A request without a login is audited (bounded, per client).
    """
    fp = faceplate(request)
    client = fp.client_of(request)
    if not fp.command_rate.hit(client):
        return error(429, "too many commands from this address: slow down", "command")
    if name not in fp.runtime.loop_names():
        return fp.unknown_loop(name)
    body = await fp.json_body(request)
    if isinstance(body, JSONResponse):
        return body
    s = fp.session_of(request)
    if s is None:
        fp.audit_refusal(client, who="anonymous", action=action, loop=name,
                         new=summary(client, f"/api/loops/{name}/{route}", body), ok=False,
                         message="refused: not logged in")  # fmt: skip
        return error(401, f"log in as {who_may}", "login")
    return s, body


def _role_refusal(request: Request, s: Any, name: str, action: str, route: str,
                  body: Any, message: str) -> None:  # fmt: skip
    """The audit row of a logged-in user's request the role does not allow (bounded)."""
    fp = faceplate(request)
    client = fp.client_of(request)
    fp.audit_refusal(client, who=s.user, action=action, loop=name, ok=False, message=message,
                     new=summary(client, f"/api/loops/{name}/{route}", body))  # fmt: skip


def _not_retained(name: str, exc: Exception) -> JSONResponse:
    msg = f"the change is in force but NOT retained (the retain file failed: {exc})"
    log.error("loop %s: %s", name, msg)
    return error(503, msg, "retain")


@router.post("/api/loops/{name}/command", response_model=None)
async def command(name: str, request: Request) -> Any:
    fp = faceplate(request)
    got = await _admitted(name, request, "command", "command", "an operator to change a loop")
    if isinstance(got, JSONResponse):
        return got
    s, body = got
    action = ",".join(sorted(str(k)[:32] for k in body))
    may = PERMISSIONS.get(s.role, frozenset())
    denied = sorted(str(k) for k in body if k in PERMISSIONS["engineer"] and k not in may)
    if denied:
        who = article(s.role)
        _role_refusal(request, s, name, action, "command", body,
                      f"refused: {who} may not change {denied[0][:32]}")  # fmt: skip
        allowed = ", ".join(sorted(PERMISSIONS.get(s.role, ()))) or "nothing"
        return error(
            403, f"{who} may not change {denied[0][:32]} (may change: {allowed})", denied[0][:32]
        )
    changes = coerce_command(body, fp.runtime.state(name))
    try:  # the loop checks the engineering ranges and audits a refusal; then it is retained
        old = await fp.on_runtime(fp.runtime.execute, name, user=s.user, **changes)
    except CommandError as exc:
        return error(422, exc.message, exc.field, exc.code)
    except (OSError, sqlite3.Error) as exc:
        return _not_retained(name, exc)
    except Exception as exc:  # the block accepted what it could not compute with
        field = exc.field if isinstance(exc, ParameterError) else next(iter(body), "")
        code = exc.code if isinstance(exc, ParameterError) else ErrorCode.BAD_PARAMETER
        msg = f"refused: {type(exc).__name__}: {str(exc)[:200]}"
        log.warning("loop %s: command %s failed: %s", name, action, msg)
        fp.runtime.audit(s.user, action, loop=name, new=json_safe(changes), ok=False,
                         message=msg, bound=True)  # fmt: skip
        return error(422, msg, str(field), code)
    retained = fp.runtime.retain is not None
    return {"ok": True, "old": json_safe(old), "retained": retained, "state": fp.loop_state(name)}


# -- live auto-tuning (engineer) ---------------------------------------------------


@router.get("/api/loops/{name}/tune", response_model=None)
async def tune_status(name: str, request: Request) -> Any:
    fp = faceplate(request)
    if not fp.may_view(request):
        return fp.not_logged_in()
    if name not in fp.runtime.loop_names():
        return fp.unknown_loop(name)
    return json_safe(fp.runtime.tuning.status(name))


@router.post("/api/loops/{name}/tune", response_model=None)
async def tune_start(name: str, request: Request) -> Any:
    return await _tune_action(name, request, "start")


@router.post("/api/loops/{name}/tune/{action}", response_model=None)
async def tune_decide(name: str, action: str, request: Request) -> Any:
    if action not in ("abort", "accept", "reject"):
        return error(404, f"unknown tuning action {action[:32]!r}", "action")
    return await _tune_action(name, request, action)


async def _tune_action(name: str, request: Request, action: str) -> Any:
    """Start, abort, accept or reject a live tuning (checks as for a command)."""
    fp = faceplate(request)
    rt = fp.runtime
    audit_action = f"tune-{action}"
    got = await _admitted(name, request, audit_action, "tune", "an engineer to tune a loop")
    if isinstance(got, JSONResponse):
        return got
    s, body = got
    if "tune" not in PERMISSIONS.get(s.role, frozenset()):
        who = article(s.role)
        _role_refusal(request, s, name, audit_action, "tune", body,
                      f"refused: {who} may not tune a loop")  # fmt: skip
        return error(403, f"{who} may not tune a loop (engineers may)", "tune")
    try:
        if action == "start":
            try:
                kw = tune_options(body, fp.bounds[name])
            except CommandError as exc:
                rt.audit(s.user, audit_action, loop=name, new=json_safe(body), ok=False,
                         message=str(exc), bound=True)  # fmt: skip
                raise
            st = await fp.on_runtime(rt.tuning.start, name, user=s.user, **kw)
        elif action == "abort":
            reason = str(body.get("reason", ""))[:200]
            st = await fp.on_runtime(rt.tuning.abort, name, user=s.user, reason=reason)
        elif action == "reject":
            st = await fp.on_runtime(rt.tuning.reject, name, user=s.user)
        else:
            proposal = body.get("proposal")
            if not isinstance(proposal, str):
                raise CommandError("proposal", "give the name of a proposal")
            outside = proposal_outside(rt, name, proposal[:64], fp.bounds[name])
            if outside is not None:
                field, msg, code = outside
                rt.audit(s.user, audit_action, loop=name, ok=False, bound=True,
                         new={"proposal": proposal[:64]}, message=f"{field}: {msg}")  # fmt: skip
                return error(422, msg, field, code)
            await fp.on_runtime(rt.tuning.accept, name, user=s.user, proposal=proposal[:64],
                                force=body.get("force") is True)  # fmt: skip
            try:  # confirmed once the accepted tuning is retained
                await fp.on_runtime(rt.durable, name)
            except (OSError, sqlite3.Error) as exc:
                return _not_retained(name, exc)
            st = rt.tuning.status(name)
    except CommandError as exc:
        return error(422, exc.message, exc.field, exc.code)
    return {"ok": True, "tuning": json_safe(st), "state": fp.loop_state(name)}
