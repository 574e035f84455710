"""The faceplate's REST and WebSocket API: every action, accepted, refused and unauthorised."""

from __future__ import annotations

import csv
import io
import json
import math
import time
from pathlib import Path

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx2")

from ctrlblocks import PID
from ctrlblocks.blocks.adrc import ADRC
from ctrlblocks.blocks.base import ErrorCode, ParameterError
from ctrlblocks.web.app import HISTORY_COLUMNS, coerce_command, csv_header

from .conftest import (
    OPERATOR,
    history,
    login,
    mode_switches,
    pi_step_bound,
    state_of,
    wait_cycles,
    wait_push,
)

RUNTIME_ACTIONS = ("alarm", "alarm-cleared")
"""Audit actions the runtime writes about its loops (not about a request)."""


def audit(client, loop=None):
    """The audit trail (of ``loop``), newest first, as ``GET /api/audit`` gives it.

    Read through the app's historian: ``/api/audit`` needs a login, and logging
    in here would change the session the test is about.  The runtime's own
    alarm rows (a late cycle on a busy machine) are left out.
    """
    rows = client.app.state.runtime.historian.audit_rows(loop, 100)[::-1]
    rows = [r for r in rows if r["action"] not in RUNTIME_ACTIONS]
    for d in rows:
        d["old"], d["new"] = (
            json.loads(d[k]) if d[k] is not None else None for k in ("old", "new")
        )
        d["ok"] = bool(d["ok"])
    return rows


def refused_code(block, **kw):
    """The code the block itself gives for ``configure(**kw)`` (independent reference)."""
    with pytest.raises(ParameterError) as exc:
        block.configure(**kw)
    return int(exc.value.code)


# -- watching ----------------------------------------------------------------------------


def test_viewer_sees_every_loop_with_sp_pv_mv_mode_and_error(client):
    st = wait_cycles(client, "fast", 3)
    assert st["cycle"] >= 3
    loops = client.get("/api/loops").json()
    assert [s["name"] for s in loops] == ["fast", "level"]
    assert [s["block"] for s in loops] == ["PID", "ADRC"]
    for s in loops:
        assert s["mode"] == "auto"
        assert s["sp"] == 1.0
        # steady start: PV = 1 and MV = 1 exactly (the lag holds y = k u = 1)
        assert s["pv"] == pytest.approx(1.0, abs=1e-9)
        assert s["mv"] == pytest.approx(1.0, abs=1e-9)
        assert s["error"] is False and s["error_id"] == 0
        # nothing wrong with the loop (a busy machine may stretch a period: a warning)
        assert [c for c in s["conditions"] if c["severity"] == "alarm"] == []
        assert set(s["status"]) <= {"overrun", "late_io", "stretched"}
    info = client.get("/api/info").json()
    assert info["user"] is None and info["role"] is None and info["may_change"] == []
    assert info["public_view"] is True and info["loops"] == ["fast", "level"]
    assert info["push_period"] <= 0.1  # >= 10 Hz


def test_page_and_chart_library_are_served_from_the_package(client):
    page = client.get("/")
    assert page.status_code == 200
    assert 'src="static/vendor/uPlot.iife.min.js"' in page.text
    assert "http://" not in page.text and "https://" not in page.text  # no CDN
    for path in ("static/vendor/uPlot.iife.min.js", "static/vendor/uPlot.min.css", "static/app.js"):
        r = client.get("/" + path)
        assert r.status_code == 200 and len(r.content) > 1000, path
    lic = client.get("/static/vendor/uPlot.LICENSE").text
    assert "MIT" in lic and "Leon Sorokin" in lic
    assert "frame-ancestors 'none'" in page.headers["content-security-policy"]


def test_websocket_pushes_every_sample_in_order(client):
    got: dict[str, list[int]] = {"fast": [], "level": []}

    def enough(msg):
        assert msg["type"] == "update"
        for name, cols in msg["samples"].items():
            got[name] += cols["seq"]
            assert set(cols) == {"seq", "t", "sp", "pv", "mv", "manual", "error_id"}
            assert all(len(v) == len(cols["seq"]) for v in cols.values())
        s = state_of(msg, "fast")
        assert {"sp", "pv", "mv", "mode", "error_id", "alarms"} <= set(s)
        return len(got["fast"]) >= 40

    wait_push(client, enough)
    seq = got["fast"]
    # no sample lost or repeated between pushes: consecutive sequence numbers from 1
    assert seq == list(range(1, len(seq) + 1))


# -- login -------------------------------------------------------------------------------


def test_wrong_password_is_refused_and_audited(client):
    r = login(client, OPERATOR[0], "wrong password")
    assert r.status_code == 401
    assert "ctrlblocks_session" not in r.cookies
    r = login(client, "mallory", OPERATOR[1])
    assert r.status_code == 401
    rows = [a for a in audit(client) if a["action"] == "login"]
    # a name that is not a user is not written down (it may be a mistyped password)
    assert [(a["who"], a["ok"]) for a in rows] == [("unknown user", False), ("alice", False)]


def test_login_sets_an_http_only_strict_cookie(client):
    r = login(client)
    assert r.status_code == 200 and r.json()["user"] == "alice"
    cookie = r.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=strict" in cookie
    assert client.get("/api/info").json()["user"] == "alice"


# -- unauthorised changes ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "body",
    [
        {"sp": 1.4},
        {"mode": "manual"},
        {"manual_value": 0.5},
        {"u_min": 0.0, "u_max": 2.0},
        {"tunings": {"kp": 3.0}},
    ],
)
def test_every_change_without_login_is_refused_and_audited(client, body):
    before = client.get("/api/loops/fast").json()
    r = client.post("/api/loops/fast/command", json=body)
    assert r.status_code == 401
    assert "log in" in r.json()["error"]["message"]
    after = client.get("/api/loops/fast").json()
    for k in ("sp", "mode", "manual_value", "u_min", "u_max"):
        if k != "manual_value" or before["mode"] == "manual":
            assert after[k] == before[k], k
    assert after["tunings"]["kp"] == 1.0
    (row,) = audit(client, "fast")
    assert row["who"] == "anonymous" and row["ok"] is False
    # a bounded summary: who, where, which fields -- never the values
    fields = [*body, *(f"tunings.{k}" for k in body.get("tunings", {}))]
    assert row["new"] == {
        "client": "testclient",
        "endpoint": "/api/loops/fast/command",
        "fields": fields,
    }


def test_logout_ends_the_session(client):
    login(client)
    assert client.post("/api/loops/fast/command", json={"sp": 1.2}).status_code == 200
    client.post("/api/logout")
    assert client.post("/api/loops/fast/command", json={"sp": 1.3}).status_code == 401
    assert client.get("/api/loops/fast").json()["sp"] == 1.2


def test_a_form_post_is_refused_as_a_csrf_guard(client):
    login(client)
    r = client.post("/api/loops/fast/command", data={"sp": "1.4"})
    assert r.status_code == 415
    assert client.get("/api/loops/fast").json()["sp"] == 1.0


# -- operator actions ---------------------------------------------------------------------------


def test_operator_changes_the_setpoint_and_the_pv_follows(client):
    login(client)
    r = client.post("/api/loops/fast/command", json={"sp": "1.5"})  # text from an input field
    assert r.status_code == 200, r.text
    assert r.json()["old"] == {"sp": 1.0}
    assert r.json()["state"]["sp"] == 1.5
    # closed loop = first-order lag, time constant 0.5 s: 90 % of the step after 1.15 s
    st = wait_push(client, lambda m: state_of(m, "fast")["pv"] > 1.45)
    assert state_of(st, "fast")["mv"] > 1.45
    (row,) = audit(client, "fast")
    assert (row["who"], row["action"], row["old"], row["new"], row["ok"]) == (
        "alice",
        "sp",
        {"sp": 1.0},
        {"sp": 1.5},
        True,
    )


def test_man_with_manual_value_and_back_to_auto_is_bumpless(client):
    login(client)
    r = client.post("/api/loops/fast/command", json={"mode": "manual"})
    assert r.status_code == 200 and r.json()["state"]["mode"] == "manual"
    # AUTO -> MAN continues from the output: the manual value is the MV at the switch
    assert r.json()["state"]["manual_value"] == pytest.approx(1.0, abs=1e-9)
    wait_cycles(client, "fast", 2)  # record MAN at the old output before changing it
    assert client.post("/api/loops/fast/command", json={"manual_value": 1.3}).status_code == 200
    # open loop in MAN: PV -> 1.3 with T = 0.5 s; wait until it has moved by 0.1
    wait_push(client, lambda m: state_of(m, "fast")["pv"] > 1.1)
    assert client.post("/api/loops/fast/command", json={"mode": "auto"}).status_code == 200
    wait_cycles(client, "fast", 5)
    cols = history(client, "fast")
    mv, mode = cols["mv"], cols["mode"]
    k_man, k_auto = mode_switches(cols)
    assert (mode[k_man], mode[k_auto]) == ("manual", "auto")
    assert mv[k_man] == pytest.approx(mv[k_man - 1], abs=1e-9)  # no bump into MAN
    assert mv[k_auto - 1] == pytest.approx(1.3, abs=1e-12)  # MAN holds the manual value
    # Into AUTO the output continues from 1.3: every step from the switch on is at most
    # one PI increment (conftest.pi_step_bound, about 0.03 here), where a restart from
    # the old integrator (1.0) would jump by 0.3 + kp |e|, about 0.4.
    for k in range(k_auto, len(mv)):
        assert abs(mv[k] - mv[k - 1]) <= pi_step_bound(cols, k), k
    assert pi_step_bound(cols, k_auto) < 0.2


def test_limits_change_clamps_the_mv_and_reversed_limits_are_refused(client):
    login(client)
    r = client.post("/api/loops/fast/command", json={"u_min": "0.2", "u_max": "0.8"})
    assert r.status_code == 200, r.text
    assert r.json()["old"] == {"u_min": 0.0, "u_max": 5.0}
    st = wait_cycles(client, "fast", 2)
    assert (st["u_min"], st["u_max"]) == (0.2, 0.8)
    assert st["mv"] == pytest.approx(0.8)  # the PI wants 1.0: held at the new high limit
    r = client.post("/api/loops/fast/command", json={"u_min": 2.0, "u_max": 1.0})
    assert r.status_code == 422
    err = r.json()["error"]
    assert (err["code"], err["code_hex"], err["name"]) == (0x8201, "16#8201", "BAD_LIMITS")
    st = client.get("/api/loops/fast").json()
    assert (st["u_min"], st["u_max"]) == (0.2, 0.8)  # the old limits stay


def test_pid_tuning_change_and_refusal_with_the_blocks_own_code(client):
    login(client)
    r = client.post("/api/loops/fast/command", json={"tunings": {"kp": "2.5", "ti": "0.8"}})
    assert r.status_code == 200, r.text
    assert r.json()["old"] == {"tunings": {"kp": 1.0, "ti": 0.5}}
    assert r.json()["state"]["tunings"]["kp"] == 2.5
    r = client.post("/api/loops/fast/command", json={"tunings": {"kp": "-1", "ti": "2"}})
    assert r.status_code == 422
    err = r.json()["error"]
    expected = refused_code(PID(kp=1.0, ti=1.0, ts=0.05), kp=-1.0)
    assert err["code"] == expected == ErrorCode.BAD_PID_COEFFS
    assert err["field"] == "tunings.kp" and "> 0" in err["message"]
    tun = client.get("/api/loops/fast").json()["tunings"]
    assert (tun["kp"], tun["ti"]) == (2.5, 0.8)  # all or nothing: ti not changed either
    rows = audit(client, "fast")
    assert [(a["action"], a["ok"]) for a in rows] == [("tunings", False), ("tunings", True)]
    assert rows[0]["message"].startswith("tunings.kp")


def test_adrc_order_change_is_bumpless_and_a_bad_b0_is_refused(client):
    login(client)
    wait_cycles(client, "level", 2)
    r = client.post("/api/loops/level/command", json={"tunings": {"order": "2", "b0": 1.5}})
    assert r.status_code == 200, r.text
    assert r.json()["state"]["tunings"]["order"] == 2
    wait_cycles(client, "level", 10)
    mv = history(client, "level")["mv"]
    # at steady state (SP = PV = MV = 1) a bumpless re-configuration keeps MV at 1
    assert max(abs(u - 1.0) for u in mv) < 1e-6
    r = client.post("/api/loops/level/command", json={"tunings": {"b0": -2}})
    assert r.status_code == 422
    expected = refused_code(ADRC(order=1, b0=2.0, omega_c=3.0, omega_o=6.0, ts=0.05), b0=-2.0)
    assert r.json()["error"]["code"] == expected == ErrorCode.BAD_B0
    assert r.json()["error"]["code_hex"] == "16#8214"
    r = client.post("/api/loops/level/command", json={"tunings": {"order": 4}})
    assert r.status_code == 422 and r.json()["error"]["code"] == ErrorCode.BAD_ORDER
    tun = client.get("/api/loops/level").json()["tunings"]
    assert (tun["order"], tun["b0"]) == (2, 1.5)


def test_unknown_loop_command_and_values_are_refused(client):
    login(client)
    assert client.post("/api/loops/nope/command", json={"sp": 1}).status_code == 404
    assert client.get("/api/loops/nope").status_code == 404
    r = client.post("/api/loops/fast/command", json={"kp": 2})
    assert r.status_code == 422 and r.json()["error"]["field"] == "kp"
    r = client.post("/api/loops/fast/command", json={"sp": "abc"})
    assert r.status_code == 422 and r.json()["error"]["field"] == "sp"
    r = client.post("/api/loops/fast/command", json={"mode": "cascade"})
    assert r.status_code == 422 and r.json()["error"]["field"] == "mode"
    r = client.post("/api/loops/fast/command", json={"tunings": {"kq": 1}})
    assert r.status_code == 422 and r.json()["error"]["field"] == "tunings"
    assert client.get("/api/loops/fast").json()["sp"] == 1.0


# -- history -------------------------------------------------------------------------------------


def test_history_for_a_period_and_its_csv_equal_the_historian(client, app):
    login(client, "vera")  # a viewer may read the history
    t0 = time.time()
    wait_cycles(client, "fast", 20)
    t1 = time.time()
    r = client.get("/api/loops/fast/history", params={"start": t0, "end": t1})
    body = r.json()
    assert body["stride"] == 1 and body["rows"] == len(body["columns"]["t_wall"])
    tw = body["columns"]["t_wall"]
    assert len(tw) >= 15 and all(t0 <= t <= t1 for t in tw) and tw == sorted(tw)
    ref = [s for s in app.state.runtime.historian.samples("fast") if t0 <= s["t_wall"] <= t1]
    assert [s["cycle"] for s in ref] == body["columns"]["cycle"]
    assert [s["mv"] for s in ref] == body["columns"]["mv"]
    r = client.get("/api/loops/fast/history.csv", params={"start": t0, "end": t1})
    assert r.headers["content-type"].startswith("text/csv")
    assert "attachment" in r.headers["content-disposition"]
    rows = list(csv.reader(io.StringIO(r.text)))
    assert rows[0] == csv_header({"sp": "m", "pv": "m", "mv": "%"})
    assert rows[0][:7] == ["t_wall [s]", "run_id", "cycle", "t [s]", "dt [s]", "sp [m]", "pv [m]"]
    assert rows[0][7] == "mv [%]" and len(rows[0]) == len(HISTORY_COLUMNS)
    assert len(rows) == len(ref) + 1
    i_pv = HISTORY_COLUMNS.index("pv")
    assert [float(x[i_pv]) for x in rows[1:]] == [s["pv"] for s in ref]


def test_history_outside_the_run_is_empty_and_bad_periods_are_refused(client):
    login(client, "vera")
    r = client.get("/api/loops/fast/history", params={"start": 1000.0, "end": 2000.0})
    assert r.json()["rows"] == 0
    r = client.get("/api/loops/fast/history", params={"start": 2000.0, "end": 1000.0})
    assert r.status_code == 400
    assert client.get("/api/loops/nope/history").status_code == 404


def test_history_is_decimated_to_max_points(client):
    login(client, "vera")
    wait_cycles(client, "fast", 12)
    body = client.get("/api/loops/fast/history", params={"max_points": 5}).json()
    n = body["rows"]
    assert body["stride"] == math.ceil(n / 5)
    assert len(body["columns"]["mv"]) == len(range(0, n, body["stride"]))


# -- helpers -------------------------------------------------------------------------------------


def test_input_field_text_is_converted_to_the_type_in_force():
    state = {"tunings": {"kp": 1.0, "order": 2, "tt": None, "y_sat": math.inf, "form": "isa"}}
    got = coerce_command(
        {
            "sp": "1.5",
            "tunings": {"kp": "2", "order": "3", "tt": "", "y_sat": "inf", "form": "parallel"},
        },
        state,
    )
    assert got == {
        "sp": 1.5,
        "tunings": {"kp": 2.0, "order": 3, "tt": None, "y_sat": math.inf, "form": "parallel"},
    }
    assert isinstance(got["tunings"]["order"], int)
    # what does not convert goes to the block unchanged (the block refuses it with its code)
    assert coerce_command({"tunings": {"kp": "x"}}, state) == {"tunings": {"kp": "x"}}


def test_demo_plant_starts_steady_and_steps_once_per_cycle(tmp_path: Path):
    import asyncio

    from ctrlblocks.runtime import FakeClock
    from ctrlblocks.web.demo import demo_runtime

    clock = FakeClock()
    rt, sim = demo_runtime(tmp_path / "h.sqlite", clock=clock, historian=None)

    async def run():
        await rt.start()
        await clock.run_until(2.0)
        await rt.stop()

    asyncio.run(run())
    p, f = rt.state("pressure"), rt.state("flow")
    assert p["pv"] == pytest.approx(1.5, abs=0.005)  # 1 mbar noise around 1.5 bar
    assert f["pv"] == pytest.approx(40.0, abs=1.0)  # 0.2 % noise around 40 %
    # one plant step per written MV (+1: the stop value written at the end)
    assert sim.steps == {"pressure": p["cycle"] + 1, "flow": f["cycle"] + 1}
    assert (p["cycle"], f["cycle"]) == (21, 41)  # 2 s at 0.1 s and 0.05 s, both ends


def test_a_runtime_run_by_another_thread_gets_commands_through_submit(tmp_path: Path, users):
    """``start_runtime=False``: the app shows a runtime on another event loop (thread)."""
    import asyncio
    import threading

    from fastapi.testclient import TestClient

    from ctrlblocks.web import create_app

    from .conftest import make_runtime

    rt = make_runtime(tmp_path)
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    asyncio.run_coroutine_threadsafe(rt.start(), loop).result(timeout=10)
    try:
        with TestClient(create_app(rt, users=users, start_runtime=False)) as client:
            login(client)
            r = client.post("/api/loops/fast/command", json={"sp": 1.25})
            assert r.status_code == 200 and r.json()["old"] == {"sp": 1.0}
            r = client.post("/api/loops/fast/command", json={"tunings": {"kp": 0.0}})
            assert r.status_code == 422 and r.json()["error"]["code"] == ErrorCode.BAD_PID_COEFFS
            assert rt.running  # the app's stop does not stop a runtime it did not start
        assert rt.loops["fast"].sp == 1.25
        assert [(a["who"], a["ok"]) for a in rt.historian.audit_rows() if a["loop"]] == [
            ("alice", True),
            ("alice", False),
        ]
    finally:
        asyncio.run_coroutine_threadsafe(rt.stop(), loop).result(timeout=10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=10)
        loop.close()


def test_five_failed_logins_lock_the_name_for_a_minute(client):
    from ctrlblocks.web.app import LOCKOUT_FAILURES

    for _ in range(LOCKOUT_FAILURES):
        assert login(client, OPERATOR[0], "guess").status_code == 401
    r = login(client)  # even the right password now
    assert r.status_code == 429 and "too many failed logins" in r.json()["error"]["message"]
    assert "ctrlblocks_session" not in r.cookies
    assert login(client, "bob", "guess").status_code == 401  # other names are not locked
    rows = [a for a in audit(client) if a["who"] == "alice"]
    assert rows[0]["message"] == "refused: too many failed logins"  # newest first
    assert len(rows) == LOCKOUT_FAILURES + 1


# -- the push: only what changed, only the loops on screen ---------------------------------------


def test_the_push_sends_only_the_watched_loops_and_only_what_changed(client):
    from ctrlblocks.web.live import ROW_FIELDS

    with client.websocket_connect("/ws") as ws:
        hello = ws.receive_json()
        assert hello["loops"] == ["fast", "level"] and hello["words"]["bad_pv"][0] == "alarm"
        ws.send_json({"type": "watch", "rows": ["fast"], "plate": None})
        pushes = [ws.receive_json() for _ in range(12)]
        ws.send_json({"type": "watch", "rows": [], "plate": "level"})
        later = [ws.receive_json() for _ in range(12)]
    # after the watch message: the row of "fast" only (what it had not had yet: its
    # state words), then only its changes; no samples (no faceplate open)
    for p in pushes[4:]:  # (the watch message is in by then)
        assert set(p["loops"]) <= {"fast"} and not p["samples"]
        assert set(p["loops"].get("fast", {})) <= set(ROW_FIELDS)
    # the open faceplate: the loop's whole state once, then what changed, and its trend
    k = next(i for i, p in enumerate(later) if "level" in p["loops"])
    assert {"tunings", "cycle", "period", "conditions"} <= set(later[k]["loops"]["level"])
    assert "fast" not in later[k]["loops"]
    assert any(p["samples"].get("level") for p in later[k:])
    assert not any(p["samples"].get("fast") for p in later[k:])
    assert all(len(p["loops"].get("level", {})) < 20 for p in later[k + 1 :])


def test_a_view_is_made_once_per_push_period_whoever_watches(client):
    hub = client.app.state.hub
    with client.websocket_connect("/ws") as a, client.websocket_connect("/ws") as b:
        for ws in (a, b):
            ws.receive_json()
            ws.send_json({"type": "watch", "rows": ["fast", "level"], "plate": None})
        for ws in (a, b):
            ws.receive_json()
        made = hub.made
        for _ in range(10):
            a.receive_json()
            b.receive_json()
    # two browsers, two rows, 10 pushes each: at most 2 rows x (10 + 2) periods, not 40
    assert hub.made - made <= 2 * 12


def test_a_command_is_confirmed_once_it_is_in_the_retain_file(client):
    """The 200 comes after the retain file has the new set point (fsync'd)."""
    import sqlite3

    login(client)
    r = client.post("/api/loops/fast/command", json={"sp": 1.3})
    assert r.status_code == 200 and r.json()["retained"] is True
    path = client.app.state.runtime.retain.path
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as c:
        (state,) = c.execute("SELECT state FROM loops WHERE name = 'fast'").fetchone()
    assert json.loads(state)["sp"] == 1.3


def test_a_command_that_cannot_be_retained_is_a_503_that_says_so(client, monkeypatch):
    login(client)

    def full_disk(name, state):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(client.app.state.runtime.retain, "save_loop", full_disk)
    r = client.post("/api/loops/fast/command", json={"sp": 1.2})
    assert r.status_code == 503
    assert "in force but NOT retained" in r.json()["error"]["message"]
