"""Helpers of the faceplate tests: a small fast plant, a runtime on it, an app, operators.

The runtime runs in real time (it is what the faceplate shows), on a plant
that moves fast: loop ``fast`` is a PI controller (kp = 1, ti = 0.5 s) on a
first-order lag (gain 1, T = 0.5 s), ts = 0.05 s, so the closed loop is a
first-order lag with time constant 0.5 s (ti = T cancels the plant pole:
L(s) = kp / (ti s)); loop ``level`` is a first-order ADRC (b0 = k/T = 2) on the
same lag.  Both start in their steady state at SP = PV = MV = 1.  Tests wait
for data through the WebSocket push or Playwright's waits, never by sleeping.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from ctrlblocks.plants import PT1, process

TS = 0.05

TEST_TOML = """
[runtime]
name = "faceplate test"

[connections.sim]
protocol = "memory"
timeout = 5.0  # in-memory I/O never waits; a busy machine must not look like a fault

[[loops]]
name = "fast"
ts = 0.05
pv = "sim:fast.pv"
mv = "sim:fast.mv"
sp = 1.0
safe_value = 0.0
block = { type = "PID", kp = 1.0, ti = 0.5, reset_value = 1.0, u_min = 0.0, u_max = 5.0 }
unit = { pv = "m", mv = "%" }
sp_range = [0.0, 2.0]
tuning_ranges = { kp = [0.1, 10.0] }

[[loops]]
name = "level"
ts = 0.05
pv = "sim:level.pv"
mv = "sim:level.mv"
sp = 1.0
safe_value = 0.0

[loops.block]
type = "ADRC"
order = 1
b0 = 2.0
omega_c = 3.0
omega_o = 6.0
u0 = 1.0
u_min = 0.0
u_max = 5.0

[historian]
path = "@HISTORY@"
flush_interval = 0.1

[web]
public_view = @PUBLIC@
"""

OPERATOR = ("alice", "correct horse battery")
"""The test engineer (user name, password): may change everything."""

USERS = {
    "alice": ("engineer", OPERATOR[1]),
    "bob": ("operator", "bob's long password"),
    "vera": ("viewer", "vera's long password"),
}
"""Every test user: name -> (role, password)."""


def lag_plants() -> dict[str, Any]:
    """The two first-order lags, steady at y = 1 (u = 1)."""
    out = {}
    for name in ("fast", "level"):
        p = process(PT1(k=1.0, t=0.5, ts=TS))
        p.reset(1.0)
        out[name] = p
    return out


def make_runtime(tmp_path: Path, public_view: bool = True) -> Any:
    """A runtime of :data:`TEST_TOML` on :func:`lag_plants`, historian in ``tmp_path``."""
    from ctrlblocks.web.demo import simulated_runtime

    text = TEST_TOML.replace('"@HISTORY@"', json.dumps(str(tmp_path / "history.sqlite")))
    text = text.replace("@PUBLIC@", "true" if public_view else "false")
    rt, _ = simulated_runtime(text, lag_plants())
    return rt


def make_users(tmp_path: Path) -> Any:
    """A users file with :data:`USERS` (cheap scrypt cost, so tests stay fast)."""
    from ctrlblocks.web import UserStore

    users = UserStore(tmp_path / "users.json")
    for name, (role, password) in USERS.items():
        users.add(name, password, role=role, n=2**10)
    return users


@pytest.fixture
def users(tmp_path: Path) -> Any:
    return make_users(tmp_path)


@pytest.fixture
def app(tmp_path: Path, users: Any) -> Any:
    pytest.importorskip("fastapi")
    from ctrlblocks.web import create_app

    return create_app(make_runtime(tmp_path), users=users)


@pytest.fixture
def client(app: Any) -> Any:
    """A TestClient whose start/stop runs the app's lifespan (runtime start/stop)."""
    from fastapi.testclient import TestClient

    with TestClient(app) as c:
        yield c


def login(client: Any, user: str = OPERATOR[0], password: str | None = None) -> Any:
    """Log ``user`` in (default password: the one of :data:`USERS`)."""
    if password is None:
        password = USERS[user][1]
    return client.post("/api/login", json={"user": user, "password": password})


def wait_push(client: Any, until: Any, limit: int = 400) -> dict[str, Any]:
    """Read WebSocket pushes until ``until(update)`` is true; return that update.

    A push carries only what changed; ``update["loops"]`` here is the list of
    the loops' whole states, the pushes so far merged (as the page keeps them).
    Fails after ``limit`` pushes (40 s at 10 Hz): the condition never came.
    """
    known: dict[str, dict[str, Any]] = {}
    with client.websocket_connect("/ws") as ws:
        hello = ws.receive_json()
        assert hello["type"] == "hello"
        for _ in range(limit):
            msg = ws.receive_json()
            for name, diff in msg["loops"].items():
                known.setdefault(name, {}).update(diff)
            view = {**msg, "loops": [dict(known[n]) for n in hello["loops"] if n in known]}
            if until(view):
                return view
    raise AssertionError(f"condition not reached in {limit} pushes")


def state_of(update: dict[str, Any], loop: str) -> dict[str, Any]:
    return next(s for s in update["loops"] if s["name"] == loop)


def wait_cycles(client: Any, loop: str, n: int) -> dict[str, Any]:
    """Wait until ``loop`` has run ``n`` more cycles than now; return its state."""
    start = client.get(f"/api/loops/{loop}").json()["cycle"]
    upd = wait_push(client, lambda m: state_of(m, loop)["cycle"] >= start + n)
    return state_of(upd, loop)


def history(client: Any, loop: str, seconds: float = 120.0) -> dict[str, list[Any]]:
    """Columns of the loop's history of the last ``seconds`` (all rows, no decimation)."""
    now = time.time()
    r = client.get(
        f"/api/loops/{loop}/history",
        params={"start": now - seconds, "end": now + 1.0, "max_points": 10**6},
    )
    assert r.status_code == 200, r.text
    return r.json()["columns"]


def mode_switches(cols: dict[str, list[Any]]) -> list[int]:
    """Row indices where the mode differs from the previous row."""
    m = cols["mode"]
    return [k for k in range(1, len(m)) if m[k] != m[k - 1]]


def finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


# -- a real server and a real browser ------------------------------------------------------------

CHROMIUM = "/usr/bin/chromium"
"""Debian's Chromium (``apt-get install chromium``; ``.ci/run`` installs it)."""

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@contextlib.contextmanager
def running_server(runtime: Any, users: Any, **server_kw: Any) -> Iterator[str]:
    """Serve the faceplate of ``runtime`` on 127.0.0.1 (a free port) in a thread; yield its URL.

    The socket is bound and listening before the thread starts, so a client
    can connect at once (it waits in the backlog until uvicorn accepts).
    Stops the server (and with it the runtime) on exit.  ``server_kw`` goes
    to :func:`~ctrlblocks.web.make_server` (``certfile``/``keyfile``: HTTPS).
    """
    from ctrlblocks.web.server import bind_socket, make_server

    sock = bind_socket("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = make_server(runtime, host="127.0.0.1", port=port, users=users, **server_kw)
    errors: list[BaseException] = []

    def run() -> None:
        try:
            asyncio.run(server.serve(sockets=[sock]))
        except BaseException as exc:  # reported by the test
            errors.append(exc)

    thread = threading.Thread(target=run, name="faceplate-server", daemon=True)
    thread.start()
    try:
        scheme = "https" if server_kw.get("certfile") else "http"
        yield f"{scheme}://127.0.0.1:{port}/"
    finally:
        server.should_exit = True
        thread.join(timeout=20)
        sock.close()
    assert not thread.is_alive(), "the faceplate server did not stop"
    assert not errors, errors


@contextlib.contextmanager
def chromium_context(viewport: tuple[int, int] = (1400, 1000)) -> Iterator[Any]:
    """A headless Chromium (Debian's, by path) with a new empty profile, driven by Playwright."""
    sync_api = pytest.importorskip("playwright.sync_api")
    if not Path(CHROMIUM).exists():
        pytest.skip(f"{CHROMIUM} not found (apt-get install chromium; .ci/run does)")
    with (
        tempfile.TemporaryDirectory(prefix="ctrlblocks-chromium-") as profile,
        sync_api.sync_playwright() as pw,
    ):
        ctx = pw.chromium.launch_persistent_context(
            profile,
            executable_path=CHROMIUM,
            args=CHROMIUM_ARGS,
            headless=True,
            bypass_csp=True,  # Playwright's waits evaluate script text
            viewport={"width": viewport[0], "height": viewport[1]},
        )
        try:
            yield ctx
        finally:
            ctx.close()


def pi_step_bound(cols: dict[str, list[Any]], k: int, kp: float = 1.0, ti: float = 0.5) -> float:
    """Largest MV change a PI (b = 1, Tustin or Euler integral) can make at row ``k`` in AUTO.

    Velocity form: du_k = kp (e_k - e_(k-1)) + kp dt_k / ti * (a mix of e_k and e_(k-1)),
    so |du_k| <= kp |e_k - e_(k-1)| + kp dt_k / ti * max(|e_k|, |e_(k-1)|), e = SP - PV,
    with the period actually used (dt_k, longer after an overrun).  A transfer to AUTO
    that is not bumpless (a restart from a stale integrator) jumps by more than this.
    """
    e = [s - p for s, p in zip(cols["sp"], cols["pv"], strict=True)]
    dt = cols["dt"][k]
    return kp * abs(e[k] - e[k - 1]) + kp * dt / ti * max(abs(e[k]), abs(e[k - 1])) + 1e-9
