"""The faceplate's defences, each probed the way an attacker (or a careless operator) would.

Request limits, the bounded audit of refusals, login lockout under
concurrency, roles, sessions that end when the users file changes,
engineering bounds, errors that are 422 and never 500, who may see what.
"""

from __future__ import annotations

import asyncio
import json
import socket
import threading
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx2")

from click.testing import CliRunner

from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.cli import main
from ctrlblocks.web import create_app
from ctrlblocks.web.app import (
    AUDIT_REFUSALS,
    CLIENT_LOGINS,
    COMMAND_REQUESTS,
    LOCKOUT_FAILURES,
    LOGIN_REQUESTS,
)
from ctrlblocks.web.bounds import TUNING_MAGNITUDE
from ctrlblocks.web.defences import MAX_BODY, MAX_FIELDS, MAX_NAME

from .conftest import USERS, login, make_runtime, make_users, running_server

CMD = "/api/loops/fast/command"


class FakeClock:
    """Time of the rate limits and the lockout, moved by the test [s]."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def rows(app: Any, loop: str | None = None) -> list[dict[str, Any]]:
    """The audit trail of the requests, newest first (straight from the historian).

    The runtime's own rows about its loops (an alarm of a late cycle on a busy
    machine) are left out.
    """
    out = app.state.runtime.historian.audit_rows(loop, 1000)[::-1]
    out = [d for d in out if d["action"] not in ("alarm", "alarm-cleared")]
    for d in out:
        d["new"] = json.loads(d["new"]) if d["new"] is not None else None
    return out


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


def client_for(app: Any) -> Any:
    from fastapi.testclient import TestClient

    return TestClient(app)


@pytest.fixture
def private(tmp_path: Path, users: Any, clock: FakeClock) -> Any:
    """A TestClient of a runtime configured with ``public_view = false`` (the default)."""
    app = create_app(make_runtime(tmp_path, public_view=False), users=users, clock=clock)
    with client_for(app) as c:
        yield c


@pytest.fixture
def timed(tmp_path: Path, users: Any, clock: FakeClock) -> Any:
    """A TestClient of a public runtime whose limits run on ``clock``; users checked each time."""
    app = create_app(make_runtime(tmp_path), users=users, clock=clock, users_check_interval=0.0)
    with client_for(app) as c:
        yield c


# -- request limits ---------------------------------------------------------------------------


def test_a_huge_declared_body_is_refused_with_413_before_it_is_sent(tmp_path: Path, users):
    """A real server answers 413 to the headers alone: the 20 MB body is never read."""
    with running_server(make_runtime(tmp_path), users) as url:
        port = int(url.rsplit(":", 1)[1].strip("/"))
        for path in ("/api/login", CMD):
            with socket.create_connection(("127.0.0.1", port), timeout=20) as s:
                s.sendall(
                    f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                    "Content-Type: application/json\r\nContent-Length: 20000000\r\n\r\n"
                    '{"user": "'.encode()
                )
                answer = s.recv(4096).decode(errors="replace")
            assert answer.startswith("HTTP/1.1 413"), answer[:200]


def test_bodies_above_the_limit_are_413_and_leave_no_trace(client, app):
    big = "x" * (MAX_BODY + 1)
    r = client.post("/api/login", json={"user": big, "password": "p"})
    assert r.status_code == 413
    r = client.post(CMD, json={"sp": 1.2, "pad": big})
    assert r.status_code == 413
    assert rows(app) == []  # nothing stored, not even a summary
    assert (
        client.post(
            CMD, content=b"[" * 3000, headers={"content-type": "application/json"}
        ).status_code
        == 400
    )


@pytest.mark.parametrize(
    ("body", "why"),
    [
        ({"tunings": {"kp": [[[[1.0]]]]}}, "nested deeper"),
        ({"tunings": {f"k{i}": 1.0 for i in range(70)}}, "more than 64"),
    ],
)
def test_json_too_deep_or_too_wide_is_refused(client, body, why):
    login(client)
    r = client.post(CMD, json=body)
    assert r.status_code == 400 and why in r.json()["error"]["message"]


def test_logins_and_commands_per_client_are_rate_limited(timed, clock):
    n_login, window = LOGIN_REQUESTS
    for _ in range(n_login):
        assert timed.post("/api/login", json={}).status_code == 400  # cheap refusals count too
    assert timed.post("/api/login", json={}).status_code == 429
    n_cmd, cwindow = COMMAND_REQUESTS
    codes = [timed.post(CMD, json={"sp": 1.0}).status_code for _ in range(n_cmd + 1)]
    assert codes == [401] * n_cmd + [429]
    clock.t += max(window, cwindow)  # a new window
    assert timed.post("/api/login", json={}).status_code == 400
    assert timed.post(CMD, json={"sp": 1.0}).status_code == 401


# -- the audit trail of refusals --------------------------------------------------------------


def test_an_anonymous_refusal_is_a_bounded_summary_without_values(client, app):
    secret = "hunter2-" + "s" * 2000
    body = {"sp": secret, "x" * 100: 1, **{f"f{i}": i for i in range(12)}}
    assert client.post(CMD, json=body).status_code == 401
    (row,) = rows(app)
    assert row["who"] == "anonymous" and row["ok"] == 0
    new = row["new"]
    assert new["client"] == "testclient" and new["endpoint"] == CMD
    assert new["fields"][:2] == ["sp", "x" * MAX_NAME] and len(new["fields"]) == MAX_FIELDS
    assert new["more_fields"] == 14 - MAX_FIELDS
    assert "hunter2" not in json.dumps(row)
    db = Path(app.state.runtime.config.historian.path)
    app.state.runtime.historian.flush()
    assert b"hunter2" not in db.read_bytes()


def test_anonymous_refusals_are_audited_at_most_n_per_window(timed, clock):
    app = timed.app
    limit, window = AUDIT_REFUSALS
    for _ in range(3 * limit):
        assert timed.post(CMD, json={"sp": 1.0}).status_code == 401
    assert len(rows(app)) == limit
    clock.t += window
    timed.post(CMD, json={"sp": 1.0})
    newest = rows(app)[0]
    assert f"({2 * limit} more not recorded)" in newest["message"]


def test_a_password_typed_as_the_user_name_is_never_stored(client, app):
    for name in ("Tr0ub4dor&3", "correct-horse-battery", "x" * 300):
        assert login(client, name, "whatever").status_code == 401
    assert [r["who"] for r in rows(app)] == ["unknown user"] * 3
    app.state.runtime.historian.flush()
    db = Path(app.state.runtime.config.historian.path).read_bytes()
    assert b"Tr0ub4dor" not in db and b"correct-horse" not in db


# -- who may see what -------------------------------------------------------------------------


def test_audit_and_history_need_a_login(client):
    for path in ("/api/audit", "/api/loops/fast/history", "/api/loops/fast/history.csv"):
        assert client.get(path).status_code == 401, path
    login(client, "vera")  # a viewer may read them
    for path in ("/api/audit", "/api/loops/fast/history", "/api/loops/fast/history.csv"):
        assert client.get(path).status_code == 200, path


def test_without_public_view_the_live_state_needs_a_login(private):
    from starlette.websockets import WebSocketDisconnect

    info = private.get("/api/info").json()
    assert info["may_view"] is False and "loops" not in info and "engineering" not in info
    assert private.get("/api/loops").status_code == 401
    assert private.get("/api/loops/fast").status_code == 401
    with pytest.raises(WebSocketDisconnect), private.websocket_connect("/ws") as ws:
        ws.receive_json()
    assert private.get("/").status_code == 200  # the page itself (to log in)
    login(private, "vera")
    assert private.get("/api/info").json()["loops"] == ["fast", "level"]
    assert private.get("/api/loops/fast").json()["name"] == "fast"
    with private.websocket_connect("/ws") as ws:
        assert ws.receive_json()["type"] == "hello"


def test_a_cross_site_websocket_is_refused(client):
    from starlette.websockets import WebSocketDisconnect

    headers = {"origin": "http://evil.example"}
    with pytest.raises(WebSocketDisconnect), client.websocket_connect("/ws", headers=headers) as ws:
        ws.receive_json()


# -- lockout under concurrency ----------------------------------------------------------------


def burst(app: Any, bodies: list[dict[str, str]]) -> tuple[list[int], list[str]]:
    """Send the logins at once (one client address); status codes, threads that hashed."""
    import httpx2 as httpx

    users = app.state.users
    verify = users.verify
    threads: list[str] = []

    def slow_verify(name: str, password: str) -> bool:
        threads.append(threading.current_thread().name)
        time.sleep(0.02)  # every request is in flight before the first check ends
        return verify(name, password)

    users.verify = slow_verify

    async def go() -> list[int]:
        transport = httpx.ASGITransport(app=app, client=("10.0.0.7", 4711))
        async with httpx.AsyncClient(transport=transport, base_url="http://faceplate") as c:
            rs = await asyncio.gather(*(c.post("/api/login", json=b) for b in bodies))
        return [r.status_code for r in rs]

    try:
        return asyncio.run(go()), threads
    finally:
        users.verify = verify


def test_forty_concurrent_wrong_logins_check_the_password_five_times(tmp_path, users):
    app = create_app(make_runtime(tmp_path), users=users, start_runtime=False)
    codes, threads = burst(app, [{"user": "alice", "password": f"guess {i}"} for i in range(40)])
    assert len(threads) == LOCKOUT_FAILURES  # counted before the hash, atomically
    assert sorted(codes) == [401] * LOCKOUT_FAILURES + [429] * (40 - LOCKOUT_FAILURES)
    # on the faceplate's own hashing thread, not the executor the runtime's historian uses
    assert set(threads) == {"ctrlblocks-password_0"}


def test_many_names_from_one_address_are_checked_at_most_n_times(tmp_path, users):
    app = create_app(make_runtime(tmp_path), users=users, start_runtime=False)
    names = [{"user": f"user{i}", "password": "guess"} for i in range(60)]
    codes, threads = burst(app, names)
    assert 1 <= len(threads) <= CLIENT_LOGINS
    assert set(codes) <= {401, 429, 503} and codes.count(401) == len(threads)


def test_a_good_login_is_not_locked_out_by_its_own_checks(timed):
    for _ in range(2 * LOCKOUT_FAILURES):
        assert login(timed, "bob").status_code == 200  # a good login gives its check back


# -- roles ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("user", "body", "status"),
    [
        ("vera", {"sp": 1.2}, 403),
        ("vera", {"mode": "manual"}, 403),
        ("bob", {"sp": 1.2}, 200),
        ("bob", {"mode": "manual", "manual_value": 1.0}, 200),
        ("bob", {"u_min": 0.0, "u_max": 2.0}, 403),
        ("bob", {"tunings": {"kp": 2.0}}, 403),
        ("alice", {"u_min": 0.0, "u_max": 2.0}, 200),
        ("alice", {"tunings": {"kp": 2.0}}, 200),
    ],
)
def test_roles_are_enforced_by_the_server(client, app, user, body, status):
    assert login(client, user).json()["role"] == USERS[user][0]
    r = client.post(CMD, json=body)
    assert r.status_code == status, r.text
    (row,) = [a for a in rows(app, "fast")]
    assert (row["who"], bool(row["ok"])) == (user, status == 200)
    if status == 403:
        assert r.json()["error"]["field"] in body and "may not change" in row["message"]
        # in English: "an operator", "a viewer" (the issue read "a operator may not ...")
        role = USERS[user][0]
        who = {"operator": "an operator", "viewer": "a viewer"}[role]
        assert r.json()["error"]["message"].startswith(f"{who} may not change ")
        assert row["message"].startswith(f"refused: {who} may not change ")


# -- sessions end when the users file changes -------------------------------------------------


@pytest.mark.parametrize(
    "change",
    [
        ["operator", "remove", "bob"],
        ["operator", "disable", "bob"],
        ["operator", "add", "bob", "--password-env", "NEW_PW"],
        ["operator", "add", "bob", "--password-env", "NEW_PW", "--role", "viewer"],
    ],
)
def test_changing_a_user_on_disk_ends_the_running_session(timed, change, monkeypatch):
    app = timed.app
    monkeypatch.setenv("NEW_PW", "a brand new password")
    assert login(timed, "bob").status_code == 200
    assert timed.post(CMD, json={"sp": 1.1}).status_code == 200
    users_file = str(app.state.users.path)
    r = CliRunner().invoke(main, [*change, "--users", users_file])
    assert r.exit_code == 0, r.output
    # another process wrote the file: the next request of bob's session is refused
    assert timed.post(CMD, json={"sp": 1.2}).status_code == 401
    assert timed.get("/api/info").json()["user"] is None
    assert login(timed, "bob").status_code == 401  # and the old password is no good
    assert timed.get("/api/loops/fast").json()["sp"] == 1.1


def test_the_users_file_is_checked_every_second_by_default(tmp_path, users, clock):
    app = create_app(make_runtime(tmp_path), users=users, clock=clock)
    with client_for(app) as c:
        assert login(c, "bob").status_code == 200
        other = make_users(tmp_path / "other")
        other.path = users.path  # another process rewrites the same file
        other.remove("bob")
        clock.t += 1.0
        assert c.post(CMD, json={"sp": 1.2}).status_code == 401


# -- engineering bounds and errors ------------------------------------------------------------


@pytest.mark.parametrize(
    ("loop", "body", "field", "code"),
    [
        ("fast", {"sp": 1e308}, "sp", ErrorCode.BAD_PARAMETER),
        ("fast", {"sp": -1e308}, "sp", ErrorCode.BAD_PARAMETER),
        ("fast", {"sp": "2.5"}, "sp", ErrorCode.BAD_PARAMETER),
        ("fast", {"u_min": -50, "u_max": -10}, "u_min", ErrorCode.BAD_LIMITS),
        ("fast", {"u_min": 0.0, "u_max": 6.0}, "u_max", ErrorCode.BAD_LIMITS),
        ("fast", {"mode": "manual", "manual_value": 1e6}, "manual_value", ErrorCode.BAD_PARAMETER),
        ("fast", {"tunings": {"kp": 50.0}}, "tunings.kp", ErrorCode.BAD_PARAMETER),
        ("fast", {"tunings": {"kp": 1e308}}, "tunings.kp", ErrorCode.BAD_PARAMETER),
        ("level", {"tunings": {"omega_o": 1e308}}, "tunings.omega_o", ErrorCode.BAD_PARAMETER),
        ("level", {"tunings": {"b0": 2 * TUNING_MAGNITUDE}}, "tunings.b0", ErrorCode.BAD_PARAMETER),
    ],
)
def test_values_outside_the_engineering_ranges_are_422_with_the_field(
    client, app, loop, body, field, code
):
    login(client)
    before = client.get(f"/api/loops/{loop}").json()
    r = client.post(f"/api/loops/{loop}/command", json=body)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert (err["field"], err["code"]) == (field, int(code))
    after = client.get(f"/api/loops/{loop}").json()
    for k in ("sp", "mode", "u_min", "u_max", "tunings"):
        assert after[k] == before[k], k
    (row,) = rows(app, loop)
    assert row["ok"] == 0 and row["message"].startswith(field)


def test_the_range_is_named_with_its_unit(client):
    login(client)
    err = client.post(CMD, json={"sp": 3.0}).json()["error"]
    assert err["message"] == "outside the engineering range [0, 2], got 3.0 m"
    err = client.post(CMD, json={"u_min": 0.0, "u_max": 9.0}).json()["error"]
    assert err["message"] == "outside the engineering range [0, 5], got 9.0 %"


def test_ranges_and_units_are_in_the_info(client):
    eng = client.get("/api/info").json()["engineering"]
    fast, level = eng["fast"], eng["level"]
    assert fast["units"] == {"pv": "m", "sp": "m", "mv": "%"}
    assert (fast["sp_range"]["lo"], fast["sp_range"]["hi"]) == (0.0, 2.0)
    assert (fast["mv_range"]["lo"], fast["mv_range"]["hi"]) == (0.0, 5.0)  # the block's limits
    kp = fast["tuning_ranges"]["kp"]
    assert (kp["lo"], kp["hi"], kp["derived"]) == (0.1, 10.0, False)  # configured
    # derived from the loop: b0 within 1/100 .. 100 times the configured 2.0; ti 0 (the
    # PID takes 0: no integral) or from a tenth of ts = 0.05 s; the ADRC's order 1, 2, 3
    b0 = level["tuning_ranges"]["b0"]
    assert (b0["lo"], b0["hi"], b0["derived"], b0["generic"]) == (0.02, 200.0, True, False)
    ti = fast["tuning_ranges"]["ti"]
    assert (ti["lo"], ti["zero_ok"], ti["unit"]) == (0.005, True, "s")
    order = level["tuning_ranges"]["order"]
    assert (order["lo"], order["hi"], order["integer"]) == (1.0, 3.0, True)
    assert level["sp_range"] is None and fast["confirm_step"] == 0.1


@pytest.mark.parametrize(
    ("what", "exc", "body"),
    [
        ("block.configure", OverflowError("math range error"), {"tunings": {"omega_o": 7.0}}),
        (
            "side.set_limits",
            ParameterError(ErrorCode.BAD_LIMITS, "u_min/u_max", "refused"),
            {"u_min": 0.0, "u_max": 4.0},
        ),
    ],
)
def test_an_exception_of_the_block_is_a_422_with_an_audit_row_never_a_500(
    client, app, monkeypatch, what, exc, body
):
    login(client)
    owner, method = what.split(".")
    target = getattr(app.state.runtime.loops["level"], owner)

    def fail(*args, **kw):
        raise exc

    monkeypatch.setattr(target, method, fail)
    before = client.get("/api/loops/level").json()
    r = client.post("/api/loops/level/command", json=body)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert type(exc).__name__ in err["message"]
    if isinstance(exc, ParameterError):
        assert (err["field"], err["code"]) == ("u_min/u_max", ErrorCode.BAD_LIMITS)
    (row,) = rows(app, "level")
    assert row["who"] == "alice" and row["ok"] == 0 and type(exc).__name__ in row["message"]
    after = client.get("/api/loops/level").json()
    assert (after["tunings"], after["u_max"]) == (before["tunings"], before["u_max"])


# -- TLS ----------------------------------------------------------------------------------------


def self_signed(tmp_path: Path) -> tuple[Path, Path]:
    """A throwaway certificate for 127.0.0.1 and its key (PEM files)."""
    import datetime
    import ipaddress

    x509 = pytest.importorskip("cryptography.x509")
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(hours=1))
        .add_extension(
            x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
            critical=False,
        )
        .sign(key, hashes.SHA256())
    )
    certfile, keyfile = tmp_path / "cert.pem", tmp_path / "key.pem"
    certfile.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    keyfile.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    return certfile, keyfile


def test_over_tls_the_session_cookie_is_secure(tmp_path: Path, users):
    import ssl

    import httpx2 as httpx

    certfile, keyfile = self_signed(tmp_path)
    rt = make_runtime(tmp_path)
    with running_server(rt, users, certfile=str(certfile), keyfile=str(keyfile)) as url:
        assert url.startswith("https://127.0.0.1:")
        ctx = ssl.create_default_context(cafile=str(certfile))
        with httpx.Client(base_url=url, verify=ctx, timeout=20) as c:
            r = c.post("/api/login", json={"user": "bob", "password": USERS["bob"][1]})
            assert r.status_code == 200
            cookie = r.headers["set-cookie"].lower()
            assert "secure" in cookie and "httponly" in cookie and "samesite=strict" in cookie
            assert c.get("/api/info").json()["user"] == "bob"  # the cookie goes back over TLS
        with pytest.raises(httpx.HTTPError):  # the server speaks TLS only
            httpx.get(url.replace("https://", "http://") + "api/info", timeout=20)


def test_over_plain_http_the_cookie_is_not_marked_secure(client):
    r = login(client, "bob")
    assert r.status_code == 200 and "secure" not in r.headers["set-cookie"].lower()


def test_a_non_loopback_address_without_tls_warns(tmp_path: Path, users, caplog):
    from ctrlblocks.web import make_server

    rt = make_runtime(tmp_path)
    with caplog.at_level("WARNING", logger="ctrlblocks.web.server"):
        make_server(rt, host="0.0.0.0", users=users)  # made, not started: nothing is bound
    assert "without TLS" in caplog.text and "0.0.0.0" in caplog.text
    caplog.clear()
    certfile, keyfile = self_signed(tmp_path)
    with caplog.at_level("WARNING", logger="ctrlblocks.web.server"):
        make_server(rt, host="0.0.0.0", users=users, certfile=str(certfile), keyfile=str(keyfile))
        make_server(rt, host="127.0.0.1", users=users)
    assert "without TLS" not in caplog.text
    with pytest.raises(ValueError, match="both"):
        make_server(rt, users=users, certfile=str(certfile))


def test_a_removed_users_live_view_closes_within_a_push(private, clock):
    from starlette.websockets import WebSocketDisconnect

    assert login(private, "vera").status_code == 200
    users_file = str(private.app.state.users.path)
    with private.websocket_connect("/ws") as ws:
        assert ws.receive_json()["type"] == "hello"
        assert ws.receive_json()["type"] == "update"
        r = CliRunner().invoke(main, ["operator", "remove", "vera", "--users", users_file])
        assert r.exit_code == 0, r.output
        clock.t += 1.0  # the users file is looked at again (once a second)
        with pytest.raises(WebSocketDisconnect) as closed:
            for _ in range(50):  # 5 s of pushes at most
                ws.receive_json()
        assert closed.value.code == 1008


# -- refusals of any role are bounded; X-Forwarded-For only from a trusted proxy ---------------


@pytest.mark.parametrize(
    ("user", "body"),
    [
        ("vera", {"sp": 1.2, "tunings": {"kp": 2.0, **{f"x{i}": "y" * 300 for i in range(9)}}}),
        ("alice", {"tunings": {"kp": "9" * 3000}}),  # refused by the loop, not the role
        ("alice", {"sp": 50.0}),  # outside sp_range
    ],
    ids=["viewer-role", "engineer-block", "engineer-range"],
)
def test_a_logged_in_users_refusals_are_bounded_like_anonymous_ones(timed, clock, user, body):
    """30 refused commands of one user: at most AUDIT_REFUSALS rows per window, each small.

    The issue measured 1.29 GB/day of refused bodies stored from one viewer."""
    app = timed.app
    limit, window = AUDIT_REFUSALS
    app.state.runtime.refusals.window.clock = lambda: clock.t  # the runtime's, per user
    assert login(timed, user).status_code == 200
    for _ in range(3 * limit):
        clock.t += window / (10 * limit)  # 30 requests in 3/10 of the window, under the rate
        r = timed.post(CMD, json=body)
        assert r.status_code in (403, 422), r.text
    refused = [r for r in rows(app, "fast") if not r["ok"]]
    assert len(refused) == limit
    assert all(len(json.dumps(r["new"])) + len(r["message"]) < 1500 for r in refused)
    clock.t += window
    timed.post(CMD, json=body)
    assert f"({2 * limit} more not recorded)" in rows(app, "fast")[0]["message"]


def _xff_app(tmp_path: Path, users: Any, clock: FakeClock, proxies: tuple[str, ...]) -> Any:
    return create_app(make_runtime(tmp_path), users=users, clock=clock, trusted_proxies=proxies)


@pytest.mark.parametrize("proxies", [(), ("127.0.0.1",), ("10.0.0.0/8",)])
def test_x_forwarded_for_counts_only_from_a_trusted_proxy(tmp_path, users, clock, proxies):
    """A different X-Forwarded-For on every request from 127.0.0.1 bypassed every
    per-address limit (the issue: 7.3 GB/day); now only a configured proxy's counts."""
    from fastapi.testclient import TestClient

    app = _xff_app(tmp_path, users, clock, proxies)
    limit, _window = COMMAND_REQUESTS
    with TestClient(app, client=("127.0.0.1", 50000)) as c:
        codes = [
            c.post(CMD, json={"sp": 1.0}, headers={"X-Forwarded-For": f"198.51.100.{k}"})
            for k in range(limit + 5)
        ]
    codes = [r.status_code for r in codes]
    trusted = "127.0.0.1" in proxies
    # one address: the budget runs out; a trusted proxy's clients: each its own budget
    assert codes.count(429) == (0 if trusted else 5)
    clients = {r["new"]["client"] for r in rows(app) if r["who"] == "anonymous"}
    assert clients == ({f"198.51.100.{k}" for k in range(limit + 5)} if trusted else {"127.0.0.1"})


def test_a_client_cannot_hide_behind_addresses_it_prepends(tmp_path, users, clock):
    """Behind a trusted proxy the client is the right-most untrusted hop of the chain."""
    from fastapi.testclient import TestClient

    app = _xff_app(tmp_path, users, clock, ("127.0.0.1", "10.0.0.0/8"))
    with TestClient(app, client=("127.0.0.1", 50000)) as c:
        c.post(CMD, json={"sp": 1.0},
               headers={"X-Forwarded-For": "1.2.3.4, 203.0.113.9, 10.1.2.3"})  # fmt: skip
    (row,) = [r for r in rows(app) if r["who"] == "anonymous"]
    assert row["new"]["client"] == "203.0.113.9"


def test_the_server_leaves_x_forwarded_for_to_the_application():
    """uvicorn believes X-Forwarded-For from 127.0.0.1 by default: switched off."""
    from ctrlblocks.web import make_server

    config = type("C", (), {"web": None, "name": "x"})()
    rt = type("R", (), {"config": config, "loop_names": lambda self: [], "loops": {},
                        "on_sample": None})()  # fmt: skip
    server = make_server(rt, port=0)
    assert server.config.proxy_headers is False


def test_the_web_table_refuses_a_trusted_proxy_that_is_not_an_address():
    from ctrlblocks.runtime import RuntimeConfigError, parse_config

    text = (
        '[connections.io]\nprotocol = "memory"\n[[loops]]\nname = "l"\nts = 0.1\n'
        'block = { type = "PID", kp = 1.0, ti = 1.0 }\npv = "io:pv"\nmv = "io:mv"\nsp = 1.0\n'
        'safe_value = 0.0\n[web]\ntrusted_proxies = ["proxy.local"]\n'
    )
    with pytest.raises(RuntimeConfigError, match=r"web\.trusted_proxies\[0\]: not an IP"):
        parse_config(text)
