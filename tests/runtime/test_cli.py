"""``ctrlblocks plant-server`` and ``ctrlblocks serve`` as processes, stopped by SIGTERM."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.runtime import SQLiteHistorian
from ctrlblocks.runtime.cli import serve as runtime_serve

from .conftest import DATA, wait_for_samples

pytestmark = pytest.mark.loopback


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def config_text(port: int, db) -> str:
    return f"""
[connections.rig]
protocol = "modbus"
port = {port}
timeout = 0.5

[[loops]]
name = "pt2"
ts = 0.05
block = {{ type = "PID", kp = 1.2, ti = 0.5, u_min = -10.0, u_max = 10.0 }}
pv = "rig:hr:0"
mv = "rig:hr:2"
sp = "rig:hr:4"
safe_value = 0.25
stop_value = -1.0

[historian]
path = "{db}"
flush_interval = 0.2
"""


def test_commands_are_registered():
    names = main.list_commands(None)
    assert {"serve", "plant-server", "history"} <= set(names)


def test_check_reports_the_loops_and_errors_name_the_key(tmp_path):
    cfg = tmp_path / "loops.toml"
    cfg.write_text(config_text(5020, tmp_path / "h.sqlite"))
    r = CliRunner().invoke(runtime_serve, [str(cfg), "--check"])
    assert r.exit_code == 0 and "1 loop(s), 1 connection(s): OK" in r.output
    cfg.write_text(config_text(5020, tmp_path / "h.sqlite").replace("kp = 1.2", "kp = 0"))
    r = CliRunner().invoke(runtime_serve, [str(cfg), "--check"])
    assert r.exit_code == 1 and "loops[0].block.kp" in r.output


def test_plant_server_and_serve_run_a_loop_and_stop_on_sigterm(tmp_path):
    port = free_port()
    db = tmp_path / "h.sqlite"
    cfg = tmp_path / "loops.toml"
    cfg.write_text(config_text(port, db))
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    cmd = [sys.executable, "-c", "from ctrlblocks.cli import main; main()"]
    # Logs go to files, not to pipes nobody drains: under load the runtime logs an
    # overrun warning per cycle, and a full pipe would block the process.
    plant_err = open(tmp_path / "plant.err", "w")  # noqa: SIM115 - closed in finally
    serve_log = open(tmp_path / "serve.log", "w")  # noqa: SIM115 - closed in finally
    plant = subprocess.Popen(
        [*cmd, "plant-server", str(DATA / "pid_pt2.toml"), "--opcua-port", "0",
         "--modbus-port", str(port)],
        stdout=subprocess.PIPE, stderr=plant_err, text=True, env=env,
    )  # fmt: skip
    serve = None
    try:
        assert plant.stdout.readline().startswith(f"Modbus TCP: 127.0.0.1:{port}")
        serve = subprocess.Popen(
            [sys.executable, "-c", "from ctrlblocks.runtime.cli import serve; serve()", str(cfg)],
            stdout=serve_log, stderr=subprocess.STDOUT, text=True, env=env,
        )  # fmt: skip
        rows = wait_for_samples(db, 20, keep=lambda r: r["pv_ok"])
        assert len(rows) >= 20, (tmp_path / "serve.log").read_text()[-2000:]
        serve.send_signal(signal.SIGTERM)
        assert serve.wait(15) == 0
    finally:
        for p in (serve, plant):
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGTERM)
                p.wait(15)
        plant_err.close()
        serve_log.close()
    assert plant.returncode == 0, (tmp_path / "plant.err").read_text()[-2000:]
    with SQLiteHistorian(db).reading() as h:
        stop = [r for r in h.audit_rows() if r["action"] == "stop"]
        runs = h.query("SELECT stopped IS NOT NULL FROM runs")
        n = len(h.samples())
    assert stop and stop[0]["ok"] == 1 and '"mv": -1.0' in stop[0]["new"]
    assert runs == [(1,)]  # the run was closed: the historian flushed on SIGTERM
    assert n >= 20


def test_plant_server_process_killed_hard_then_restarted_loop_reconnects(tmp_path):
    """SIGKILL the plant-server process mid-run: the loop goes to its safe value in the
    cycle that notices, reconnects to the new process, and continues without a bump at
    the device: from the MV the new process holds (its start value 0.5), read back."""
    import asyncio

    from ctrlblocks.runtime import Runtime, parse_config

    port = free_port()
    db = tmp_path / "h.sqlite"
    # a generous I/O timeout: the SIGKILL closes the connection (seen at once, no timeout
    # needed), while a loaded machine answering late must not make an early sample bad
    text = config_text(port, db).replace("timeout = 0.5", "timeout = 2.0\nreconnect_max = 0.2")
    text = text.replace('type = "PID", kp = 1.2, ti = 0.5', 'type = "ADRC", order = 1, b0 = 4.0')
    cmd = [sys.executable, "-c", "from ctrlblocks.cli import main; main()", "plant-server"]
    args = [str(DATA / "pid_pt2.toml"), "--opcua-port", "0", "--modbus-port", str(port)]

    def start_plant():
        p = subprocess.Popen([*cmd, *args], stdout=subprocess.PIPE, text=True)
        assert p.stdout.readline().startswith("Modbus TCP")
        return p

    async def main():
        plant = await asyncio.to_thread(start_plant)
        rt = Runtime(parse_config(text))
        await rt.start()
        lp = rt.loops["pt2"]
        try:
            while lp.cycle_count < 20:
                await asyncio.sleep(0.05)
            plant.kill()  # SIGKILL: no goodbye
            await asyncio.to_thread(plant.wait)
            n = lp.cycle_count
            while lp.cycle_count < n + 10:
                await asyncio.sleep(0.05)
            plant = await asyncio.to_thread(start_plant)
            for _ in range(400):
                if lp.pv_ok and rt.connections["rig"].reconnects:
                    break
                await asyncio.sleep(0.05)
            n = lp.cycle_count
            while lp.cycle_count < n + 10:
                await asyncio.sleep(0.05)
        finally:
            await rt.stop()
            plant.send_signal(signal.SIGTERM)
            await asyncio.to_thread(plant.wait, 15)

    asyncio.run(main())
    with SQLiteHistorian(db).reading() as h:
        rows = h.samples()
    ok = [bool(r["pv_ok"]) for r in rows]
    first_bad = ok.index(False)
    first_back = ok.index(True, first_bad)
    assert first_bad >= 20
    assert all(r["mv"] == 0.25 for r in rows[first_bad:first_back])  # the safe value
    assert rows[first_back]["mv"] == pytest.approx(0.5, abs=1e-6)  # the device's MV: no bump
    assert all(ok[first_back:])
