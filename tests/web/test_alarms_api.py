"""The faceplate's process alarms: the list, acknowledgement by role, shelving, the journal."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx2")

from .conftest import TEST_TOML, USERS, lag_plants, login

# the fast loop's PV sits at 1.0: H at 0.5 is active from the first cycles
ALARMS = 'alarms = { h = 0.5, hh = 3.0, deadband = 0.05 }\nunit = { pv = "m", mv = "%" }'


@pytest.fixture
def alarm_client(tmp_path: Path, users: Any) -> Any:
    from fastapi.testclient import TestClient

    from ctrlblocks.web import create_app
    from ctrlblocks.web.demo import simulated_runtime

    text = TEST_TOML.replace('"@HISTORY@"', json.dumps(str(tmp_path / "history.sqlite")))
    text = text.replace("@PUBLIC@", "true").replace('unit = { pv = "m", mv = "%" }', ALARMS)
    rt, _ = simulated_runtime(text, lag_plants())
    with TestClient(create_app(rt, users=users)) as c:
        yield c


def _wait_alarm(client: Any, state: str, timeout: float = 30.0) -> dict:
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        st = client.get("/api/alarms").json()["loops"].get("fast")
        if st and any(a["name"] == "H" and a["state"] == state for a in st["alarms"]):
            return st
        time.sleep(0.05)
    raise AssertionError(f"alarm H never {state}")


def test_the_alarm_list_shows_the_loop_state_at_a_glance(alarm_client) -> None:
    st = _wait_alarm(alarm_client, "UNACK")
    assert st["unacknowledged"] == 1 and st["worst"] == 2
    (h,) = [a for a in st["alarms"] if a["name"] == "H"]
    assert h["active"] and h["limit"] == 0.5 and h["value"] == pytest.approx(1.0, abs=0.05)
    assert "level" not in alarm_client.get("/api/alarms").json()["loops"]  # no alarms configured


def test_a_viewer_may_not_acknowledge_an_operator_may(alarm_client) -> None:
    _wait_alarm(alarm_client, "UNACK")
    anon = alarm_client.post("/api/loops/fast/alarms/ack", json={"alarm": "H"})
    assert anon.status_code == 401
    login(alarm_client, "vera", USERS["vera"][1])
    r = alarm_client.post("/api/loops/fast/alarms/ack", json={"alarm": "H"})
    assert r.status_code == 403 and "viewer may not ack" in r.json()["error"]["message"]
    alarm_client.post("/api/logout")
    login(alarm_client, "bob", USERS["bob"][1])
    r = alarm_client.post("/api/loops/fast/alarms/ack", json={"alarm": "H"})
    assert r.status_code == 200 and r.json()["changed"] == ["H"]
    _wait_alarm(alarm_client, "ACKED")
    rows = alarm_client.app.state.runtime.historian.audit_rows("fast", 100)
    acks = [r for r in rows if r["action"] == "alarm H" and r["who"] == "bob"]
    assert [json.loads(r["new"]) for r in acks] == ["ACKED"]


def test_shelving_needs_a_limited_time_and_a_known_alarm(alarm_client) -> None:
    _wait_alarm(alarm_client, "UNACK")
    login(alarm_client, "bob", USERS["bob"][1])
    bad = alarm_client.post("/api/loops/fast/alarms/shelve", json={"alarm": "H", "seconds": 1e9})
    assert bad.status_code == 422
    unknown = alarm_client.post("/api/loops/fast/alarms/ack", json={"alarm": "<script>"})
    assert unknown.status_code == 422
    ok = alarm_client.post("/api/loops/fast/alarms/shelve", json={"alarm": "H", "seconds": 60})
    assert ok.status_code == 200
    _wait_alarm(alarm_client, "SHELVED")
    alarm_client.post("/api/loops/fast/alarms/unshelve", json={"alarm": "H"})
    _wait_alarm(alarm_client, "UNACK")


def test_the_page_loads_the_alarm_component(alarm_client) -> None:
    page = alarm_client.get("/").text
    assert 'src="static/alarms.js"' in page and 'id="alarm-list"' in page
    js = alarm_client.get("/static/alarms.js").text
    assert "innerHTML" not in js  # text only
