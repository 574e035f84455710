"""Process alarms (:mod:`ctrlblocks.runtime.health`): the list, acknowledge, shelve, unshelve."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ...blocks.alarms import ALARM_NAMES
from ...blocks.base import ParameterError
from ..context import article, error
from ..live import json_safe
from . import faceplate
from .commands import _admitted, _role_refusal

__all__ = ["ALARM_ROLES", "router"]

router = APIRouter()

ALARM_ROLES = frozenset({"operator", "engineer"})
"""The roles that may acknowledge, shelve and unshelve process alarms (a viewer may not)."""


@router.get("/api/alarms", response_model=None)
async def alarms_all(request: Request) -> Any:
    """Every loop's alarm state at a glance and its annunciated alarms."""
    fp = faceplate(request)
    if not fp.may_view(request):
        return fp.not_logged_in()
    out = {}
    for name in fp.runtime.health.loops:
        st = fp.runtime.health.status(name)
        st["alarms"] = [a for a in st["alarms"] if a["state"] != "NORMAL"]
        out[name] = json_safe(st)
    return {"loops": out}


@router.post("/api/loops/{name}/alarms/{action}", response_model=None)
async def alarm_action(name: str, action: str, request: Request) -> Any:
    """Acknowledge (``{"alarm": "H"}``, or all without it), shelve or unshelve an alarm."""
    fp = faceplate(request)
    health = fp.runtime.health
    if action not in ("ack", "shelve", "unshelve"):
        return error(404, f"unknown alarm action {action[:32]!r}", "action")
    audit_action = f"alarm-{action}"
    got = await _admitted(name, request, audit_action, f"alarms/{action}",
                          "an operator to acknowledge alarms")  # fmt: skip
    if isinstance(got, JSONResponse):
        return got
    s, body = got
    if s.role not in ALARM_ROLES:
        who = article(s.role)
        _role_refusal(request, s, name, audit_action, f"alarms/{action}", body,
                      f"refused: {who} may not {action} alarms")  # fmt: skip
        return error(403, f"{who} may not {action} alarms (operators may)", "alarm")
    alarm = body.get("alarm")
    if alarm is not None and (not isinstance(alarm, str) or alarm not in ALARM_NAMES):
        return error(422, f"alarm must be one of {', '.join(ALARM_NAMES)}", "alarm")
    try:
        if action == "ack":
            changed = health.acknowledge(name, alarm, s.user)
        elif alarm is None:
            return error(422, "name the alarm to shelve or unshelve", "alarm")
        elif action == "shelve":
            seconds = body.get("seconds")
            if isinstance(seconds, bool) or not isinstance(seconds, (int, float)):
                return error(422, "seconds must be a number", "seconds")
            health.shelve(name, alarm, float(seconds), s.user)
            changed = [alarm]
        else:
            health.unshelve(name, alarm, s.user)
            changed = [alarm]
    except KeyError:
        return error(404, f"loop {name[:64]!r} has no alarms", "loop")
    except ParameterError as exc:
        return error(422, exc.message, "seconds", exc.code)
    return {"ok": True, "changed": changed, "status": json_safe(health.status(name))}
