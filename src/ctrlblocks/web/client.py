"""A small client of the faceplate's REST API (the command line's way to a running runtime).

``ctrlblocks serve`` runs the loops and the faceplate; other commands talk to
that running runtime through the same API a browser uses -- with a login, so
the role checks, the engineering ranges and the audit trail apply to them as
to the page.  Standard library only (:mod:`urllib.request`, a cookie jar for
the session cookie).
"""

from __future__ import annotations

import http.cookiejar
import json
import ssl
import urllib.error
import urllib.parse
import urllib.request
from typing import Any

__all__ = ["FaceplateClient", "FaceplateError"]

TIMEOUT = 10.0
"""Seconds one request may take."""


class FaceplateError(Exception):
    """A refused request (``status`` the HTTP status, 0 when the server was not reached)."""

    def __init__(self, status: int, message: str, field: str = "") -> None:
        self.status, self.message, self.field = status, message, field
        super().__init__(message)


class FaceplateClient:
    """Requests to the faceplate at ``url`` (``http://127.0.0.1:8000/``), with its session cookie.

    Parameters
    ----------
    url : str
        The faceplate's address (``http`` or ``https``).
    cafile : str, optional
        CA or self-signed certificate (PEM) that signs the server's (HTTPS).
    """

    def __init__(self, url: str, *, cafile: str | None = None, timeout: float = TIMEOUT) -> None:
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise FaceplateError(0, f"not a faceplate address: {url!r} (e.g. http://127.0.0.1:8000)")
        self.url = f"{parts.scheme}://{parts.netloc}/"
        self.timeout = timeout
        handlers: list[Any] = [urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar())]
        if parts.scheme == "https":
            try:
                ctx = ssl.create_default_context(cafile=cafile)
            except (ssl.SSLError, OSError) as exc:  # not a PEM certificate
                why = getattr(exc, "reason", None) or exc.strerror or exc
                raise FaceplateError(
                    0, f"{cafile}: not a certificate in PEM ({why})", "--cafile"
                ) from None
            handlers.append(urllib.request.HTTPSHandler(context=ctx))
        self._opener = urllib.request.build_opener(*handlers)

    def request(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        """``method`` ``path`` (e.g. ``/api/loops/p3/tune``) with a JSON body; the JSON answer."""
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(
            urllib.parse.urljoin(self.url, path.lstrip("/")),
            data=data,
            method=method,
            headers={"Content-Type": "application/json", "Accept": "application/json"},
        )
        try:
            with self._opener.open(req, timeout=self.timeout) as resp:
                return json.loads(resp.read() or b"null")
        except urllib.error.HTTPError as exc:
            try:
                err = json.loads(exc.read()).get("error") or {}
            except (ValueError, AttributeError):
                err = {}
            raise FaceplateError(
                exc.code, str(err.get("message") or exc.reason), str(err.get("field") or "")
            ) from None
        except (urllib.error.URLError, OSError) as exc:
            reason = getattr(exc, "reason", exc)
            raise FaceplateError(
                0, f"cannot reach the faceplate at {self.url}: {reason} (is 'ctrlblocks serve' "
                "running there? --url gives its address)"
            ) from None

    def get(self, path: str) -> Any:
        return self.request("GET", path)

    def post(self, path: str, body: dict[str, Any] | None = None) -> Any:
        return self.request("POST", path, {} if body is None else body)

    def login(self, user: str, password: str) -> str:
        """Log in; the role."""
        ans = self.post("/api/login", {"user": user, "password": password})
        return str(ans.get("role", ""))

    def logout(self) -> None:
        self.post("/api/logout")
