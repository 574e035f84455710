"""Login and logout: the lockout counts a password check before the hash is computed."""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ..auth import NAME_RE
from ..context import COOKIE, LOCKOUT_SECONDS, MAX_PENDING_HASHES, error
from ..defences import summary
from . import faceplate

__all__ = ["router"]

router = APIRouter()


@router.post("/api/login", response_model=None)
async def login(request: Request) -> Any:
    fp = faceplate(request)
    client = fp.client_of(request)
    if not fp.login_rate.hit(client):
        return error(429, "too many requests from this address: wait a minute", "login")
    body = await fp.json_body(request)
    if isinstance(body, JSONResponse):
        return body
    user, password = body.get("user"), body.get("password")
    if not isinstance(user, str) or not isinstance(password, str):
        return error(400, "give user and password as strings", "user")
    if len(password) > 1024:
        return error(400, "the password is too long", "password")
    fp.check_users()
    # a name that is not a user is never written down: it may be a password
    known = bool(NAME_RE.match(user)) and fp.users.exists(user)
    who = user if known else "unknown user"
    key = user if NAME_RE.match(user) else "(invalid name)"
    refused = fp.guard.admit(key, client)
    if refused is not None:
        fp.audit_refusal(client, who=who, action="login", ok=False, message=f"refused: {refused}",
                         new=summary(client, "/api/login", {}))  # fmt: skip
        return error(429, f"{refused}: try again in {LOCKOUT_SECONDS:g} s", "user")
    if fp.hashing["pending"] >= MAX_PENDING_HASHES:
        fp.guard.withdraw(key, client)
        return error(503, "too many logins at once: try again", "login")
    pool = fp.hashing_pool()
    fp.hashing["pending"] += 1
    try:
        loop = asyncio.get_running_loop()
        ok = await loop.run_in_executor(pool, fp.users.verify, user, password)
    finally:
        fp.hashing["pending"] -= 1
    if not ok:
        fp.audit_refusal(client, who=who, action="login", ok=False,
                         message="wrong user name or password",
                         new=summary(client, "/api/login", {}))  # fmt: skip
        return error(401, "wrong user name or password", "password")
    fp.guard.succeeded(key, client)
    fp.runtime.audit(user, "login", ok=True, new={"client": client})
    role = fp.users.role(user) or "operator"
    token = fp.sessions.create(user, role, fp.users.fingerprint(user))
    resp = JSONResponse({"ok": True, "user": user, "role": role})
    resp.set_cookie(
        COOKIE,
        token,
        httponly=True,
        samesite="strict",
        secure=request.url.scheme == "https",
        max_age=int(3600 * fp.sessions.hours),
        path="/",
    )
    return resp


@router.post("/api/logout")
async def logout(request: Request) -> JSONResponse:
    fp = faceplate(request)
    s = fp.session_of(request)
    if s is not None:
        fp.runtime.audit(s.user, "logout")
    fp.sessions.end(request.cookies.get(COOKIE))
    resp = JSONResponse({"ok": True})
    resp.delete_cookie(COOKIE, path="/")
    return resp
