"""Live auto-tuning from the faceplate's API: engineer only, live progress, accept or reject."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from .conftest import TEST_TOML, TS, lag_plants, login

pytest.importorskip("fastapi")


def wait_tuning(client: Any, loop: str, until: Any, timeout: float = 60.0) -> dict[str, Any]:
    """Poll ``GET /api/loops/LOOP/tune`` until ``until(status)``; fail after ``timeout`` s."""
    t_end = time.monotonic() + timeout
    st = None
    while time.monotonic() < t_end:
        st = client.get(f"/api/loops/{loop}/tune").json()
        if st is not None and until(st):
            return st
        time.sleep(0.05)
    raise AssertionError(f"tuning of {loop} not reached in {timeout} s: {st}")


def finished(st: dict[str, Any]) -> bool:
    return st["state"] != "running" and (st["state"] != "done" or st["margins_ready"])


def audit_actions(client: Any, loop: str) -> list[tuple[str, str, bool]]:
    return [(r["who"], r["action"], r["ok"]) for r in client.get(f"/api/audit?loop={loop}").json()]


def dead_time_runtime(tmp_path: Path, public_view: bool) -> Any:
    """The test runtime with loop ``fast`` on k e^(-0.2 s)/(0.5 s + 1) (k = 1), at y = 1."""
    from ctrlblocks.plants import FOPDT, process
    from ctrlblocks.web.demo import simulated_runtime

    plants = lag_plants()
    plants["fast"] = process(FOPDT(k=1.0, t=0.5, dead_time=0.2, ts=TS))
    plants["fast"].reset(1.0)
    text = TEST_TOML.replace('"@HISTORY@"', json.dumps(str(tmp_path / "history.sqlite")))
    rt, _ = simulated_runtime(text.replace("@PUBLIC@", json.dumps(public_view)), plants)
    return rt


@pytest.fixture
def dead_time_client(tmp_path: Path, users: Any) -> Any:
    """A TestClient of the faceplate of :func:`dead_time_runtime`."""
    from fastapi.testclient import TestClient

    from ctrlblocks.web import create_app

    with TestClient(create_app(dead_time_runtime(tmp_path, True), users=users)) as c:
        yield c


def test_only_an_engineer_may_tune_and_every_refusal_is_audited(client: Any) -> None:
    assert client.get("/api/loops/fast/tune").json() is None
    body = {"method": "step", "amplitude": 0.5}
    assert client.post("/api/loops/fast/tune", json=body).status_code == 401
    for user in ("vera", "bob"):  # viewer, operator
        login(client, user)
        r = client.post("/api/loops/fast/tune", json=body)
        assert r.status_code == 403 and "engineers may" in r.json()["error"]["message"]
        assert client.post("/api/loops/fast/tune/abort", json={}).status_code == 403
    login(client)  # the engineer
    r = client.post("/api/loops/fast/tune", json={**body, "mv_max": 9.0})
    assert r.status_code == 422 and r.json()["error"]["field"] == "mv_max"
    r = client.post("/api/loops/fast/tune", json={**body, "guess": 1})
    assert r.status_code == 422 and r.json()["error"]["field"] == "guess"
    assert client.post("/api/loops/fast/tune/reject", json={}).status_code == 422
    assert client.post("/api/loops/nope/tune", json=body).status_code == 404
    assert client.get("/api/loops/fast/tune").json() is None  # nothing started
    actions = audit_actions(client, "fast")
    assert ("bob", "tune-start", False) in actions and ("vera", "tune-abort", False) in actions
    assert ("alice", "tune-start", False) in actions


def test_an_engineer_runs_a_step_test_sees_the_model_and_margins_and_accepts(
    dead_time_client: Any,
) -> None:
    c = dead_time_client
    login(c)
    r = c.post("/api/loops/fast/tune", json={"method": "step", "amplitude": "0.5",
                                             "pv_max": "1.9", "pv_min": ""})  # fmt: skip
    assert r.status_code == 200, r.text
    assert r.json()["tuning"]["state"] == "running"
    running = wait_tuning(c, "fast", lambda s: s["elapsed"] > 1.5)  # live progress
    assert running["state"] == "running" and running["mv"] == pytest.approx(1.5)
    assert c.get("/api/loops/fast").json()["tuning"]["state"] == "running"
    st = wait_tuning(c, "fast", finished)
    assert st["state"] == "done", st["reason"]
    m = st["model"]  # the plant: k = 1, T = 0.5 s, L = 0.2 s
    assert m["gain"] == pytest.approx(1.0, rel=0.05)
    assert m["time_constant"] == pytest.approx(0.5, rel=0.05)
    assert m["dead_time"] == pytest.approx(0.2, abs=TS)
    assert set(st["margins"]) == set(st["proposals"])
    amigo = st["margins"]["PID_AMIGO"]
    assert amigo["stable"] and 1.1 < amigo["ms"] < 2.0 and amigo["pm"] > 30
    assert c.get("/api/loops/fast").json()["tunings"]["kp"] == 1.0  # nothing applied yet
    r = c.post("/api/loops/fast/tune/accept", json={"proposal": "PID_AMIGO"})
    assert r.status_code == 200, r.text
    tun = r.json()["state"]["tunings"]
    assert tun["kp"] == pytest.approx(st["proposals"]["PID_AMIGO"]["kp"])
    assert r.json()["tuning"]["state"] == "accepted"
    assert r.json()["state"]["mode"] == "auto"
    actions = audit_actions(c, "fast")
    for a in (("alice", "tune-start", True), ("runtime", "tune-result", True),
              ("alice", "tune-accept", True), ("alice", "tunings", True)):  # fmt: skip
        assert a in actions


def test_a_proposal_outside_the_engineering_range_is_refused_and_the_result_rejected(
    client: Any,
) -> None:
    login(client)
    r = client.post("/api/loops/fast/tune", json={"method": "step", "amplitude": 0.5})
    assert r.status_code == 200, r.text
    st = wait_tuning(client, "fast", finished)
    assert st["state"] == "done"
    # a lag without dead time: the model rules give absurd gains, the margins say so
    assert not st["margins"]["PID_AMIGO"]["stable"]
    r = client.post("/api/loops/fast/tune/accept", json={"proposal": "PID_AMIGO", "force": True})
    assert r.status_code == 422 and r.json()["error"]["field"] == "tunings.kp"
    r = client.post("/api/loops/fast/tune/accept", json={"proposal": "PID_X"})
    assert r.status_code == 422 and "proposals: ['PID_AMIGO', 'PID_MIGO', 'PI_SIMC']" in r.text
    r = client.post("/api/loops/fast/tune/reject", json={})
    assert r.status_code == 200 and r.json()["tuning"]["state"] == "rejected"
    assert r.json()["state"]["tunings"]["kp"] == 1.0
    assert ("alice", "tune-reject", True) in audit_actions(client, "fast")


def test_the_command_line_tunes_a_loop_of_a_running_faceplate(tmp_path: Path, users: Any) -> None:
    """``ctrlblocks tune-live`` against a real server on 127.0.0.1: start, wait, accept."""
    from click.testing import CliRunner

    from ctrlblocks.cli import main

    from .conftest import OPERATOR, running_server

    rt = dead_time_runtime(tmp_path, False)
    env = {"CTRLBLOCKS_USER": OPERATOR[0], "PW": OPERATOR[1]}
    runner = CliRunner()
    with running_server(rt, users) as url:
        def cli(*args: str) -> Any:
            return runner.invoke(main, ["tune-live", "--url", url, "--loop", "fast",
                                        "--password-env", "PW", *args], env=env)  # fmt: skip

        res = cli("--method", "step", "--amplitude", "0.5", "--pv-max", "1.9")
        assert res.exit_code == 0, res.output
        assert "step test: done" in res.output and "model: FOPDT gain 1" in res.output
        assert "PID_AMIGO" in res.output and "Ms " in res.output
        assert "nothing applied" in res.output
        res = cli("--accept", "PID_AMIGO")
        assert res.exit_code == 0 and "accepted by alice: PID_AMIGO" in res.output, res.output
        res = cli("--status", "--json")
        assert json.loads(res.output)["state"] == "accepted"
        res = cli("--abort")
        assert res.exit_code == 1 and "no test is running" in res.output
        assert "Traceback" not in res.output
        res = runner.invoke(main, ["tune-live", "--url", url, "--loop", "fast", "--user", "bob",
                                   "--password-env", "PW", "--reject"],
                            env={"PW": "bob's long password"})  # fmt: skip
        assert res.exit_code == 1 and "live tuning needs an engineer" in res.output
    res = runner.invoke(main, ["tune-live", "--url", url, "--loop", "fast", "--status"])
    assert res.exit_code == 1 and "cannot reach the faceplate" in res.output
    res = runner.invoke(main, ["tune-live", "--loop", "fast", "--method", "step"])
    assert res.exit_code == 2 and "--amplitude" in res.output
