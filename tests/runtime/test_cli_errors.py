"""What a new user hits on the runtime's commands: clear errors, nothing created, no traceback."""

from __future__ import annotations

import importlib.util
import os
import signal
import socket
import subprocess
import sys

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.runtime import SQLiteHistorian, parse_config
from ctrlblocks.runtime.loop import Sample

from .conftest import DATA, loop_toml, wait_for_samples


def cli(*args: str):
    return CliRunner().invoke(main, list(args))


def no_module(monkeypatch, *names: str) -> None:
    """Make ``importlib.util.find_spec`` say the packages ``names`` are not installed."""
    real = importlib.util.find_spec

    def find_spec(name, *a, **kw):
        return None if name in names else real(name, *a, **kw)

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)


def history_db(path):
    h = SQLiteHistorian(path)
    h.open()
    for k in range(3):
        h.record(Sample("level", k, 0.0, 0.1 * k, 0.1, 1.0, 0.5, 0.2, "auto", 0, True, True, False))
    h.close()


def test_history_of_a_missing_file_is_an_error_and_creates_nothing(tmp_path):
    r = cli("history", str(tmp_path / "nope.sqlite"), str(tmp_path / "out.csv"))
    assert (r.exit_code == 1 and r.exception is None) or isinstance(r.exception, SystemExit)
    assert "no such historian database" in r.output
    assert "Traceback" not in r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_serve_with_a_historian_that_cannot_be_opened_says_which_file_and_why(tmp_path):
    cfg = tmp_path / "loops.toml"
    where = tmp_path / "no such folder" / "h.sqlite"
    cfg.write_text(
        '[connections.io]\nprotocol = "memory"\n'
        + loop_toml(ts=0.1)
        + f'[historian]\npath = "{where}"\n[retain]\nenabled = false\n'
    )
    r = cli("serve", str(cfg), "--no-web")
    assert r.exit_code == 1 and "Traceback" not in r.output
    assert f"historian: {where}: OperationalError: unable to open database file" in r.output


def test_history_to_an_unknown_format_is_an_error(tmp_path):
    db = tmp_path / "h.sqlite"
    history_db(db)
    r = cli("history", str(db), str(tmp_path / "x.xlsx"))
    assert r.exit_code == 1
    assert "unknown export format '.xlsx'; use .csv or .parquet" in r.output
    assert not (tmp_path / "x.xlsx").exists()


def test_history_of_an_unknown_loop_names_the_loops_and_writes_nothing(tmp_path):
    db = tmp_path / "h.sqlite"
    history_db(db)
    r = cli("history", str(db), str(tmp_path / "out.csv"), "--loop", "nope")
    assert r.exit_code == 1
    assert "no samples of loop 'nope'; loops: level" in r.output
    assert not (tmp_path / "out.csv").exists()
    ok = cli("history", str(db), str(tmp_path / "out.csv"), "--loop", "level")
    assert ok.exit_code == 0 and len((tmp_path / "out.csv").read_text().splitlines()) == 4


def test_history_to_parquet_without_pyarrow_says_how_to_install_it(tmp_path, monkeypatch):
    db = tmp_path / "h.sqlite"
    history_db(db)
    no_module(monkeypatch, "pyarrow")
    r = cli("history", str(db), str(tmp_path / "x.parquet"))
    assert r.exit_code == 1 and "pip install pyarrow" in r.output
    assert "Traceback" not in r.output and not (tmp_path / "x.parquet").exists()


def test_plant_server_on_a_busy_port_says_so_once(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = cli(
            "plant-server", str(DATA / "pid_pt2.toml"), "--opcua-port", str(port),
            "--modbus-port", "0",
        )  # fmt: skip
    assert r.exit_code == 1
    assert r.output.count("Address already in use") == 1
    assert f"127.0.0.1:{port}" in r.output and "Traceback" not in r.output


@pytest.mark.parametrize(
    ("missing", "args"),
    [("asyncua", ["--modbus-port", "0"]), ("pymodbus", ["--opcua-port", "0"])],
)
def test_plant_server_without_the_runtime_extra_says_how_to_install_it(monkeypatch, missing, args):
    no_module(monkeypatch, missing)
    r = cli("plant-server", str(DATA / "pid_pt2.toml"), *args)
    assert r.exit_code == 1
    assert f"needs the {missing} package" in r.output
    assert "pip install 'ctrlblocks[runtime]'" in r.output


MODBUS_LOOP = '[connections.rig]\nprotocol = "modbus"\n' + loop_toml(
    conn="rig", pv="hr:0", mv="hr:2"
)


@pytest.mark.parametrize("extra", [["--check"], ["--no-web"], []])
def test_serve_without_the_protocols_package_fails_with_the_install_command(
    tmp_path, monkeypatch, extra
):
    cfg = tmp_path / "loops.toml"
    cfg.write_text(MODBUS_LOOP)
    no_module(monkeypatch, "pymodbus")
    r = cli("serve", str(cfg), *extra)
    assert r.exit_code == 1, r.output
    assert "connections.rig.protocol: modbus needs the pymodbus package" in r.output
    assert "pip install 'ctrlblocks[runtime]'" in r.output


def test_the_default_historian_is_where_serve_runs_not_beside_the_file(tmp_path, monkeypatch):
    (tmp_path / "etc").mkdir()
    (tmp_path / "run").mkdir()
    monkeypatch.chdir(tmp_path / "run")
    text = '[connections.io]\nprotocol = "memory"\n' + loop_toml()
    cfg = parse_config(text, file=str(tmp_path / "etc" / "loops.toml"), base=tmp_path / "etc")
    assert cfg.historian.path == str((tmp_path / "run" / "ctrlblocks-history.sqlite").resolve())
    given = parse_config(text + '[historian]\npath = "h.sqlite"\n', base=tmp_path / "etc")
    assert given.historian.path == str(tmp_path / "etc" / "h.sqlite")  # relative to the file


@pytest.mark.loopback
def test_the_readme_sequence_serve_then_history_works_from_another_directory(tmp_path):
    """``serve ../etc/loops.toml`` prints where its historian is; ``history`` finds it.

    (``--no-web``: the faceplate's ``serve`` prints the same lines, without a web server here.)
    """
    (tmp_path / "etc").mkdir()
    run = tmp_path / "run"
    run.mkdir()
    (tmp_path / "etc" / "loops.toml").write_text(
        '[connections.io]\nprotocol = "memory"\n' + loop_toml(ts=0.05)
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    exe = [sys.executable, "-c", "from ctrlblocks.cli import main; main()"]
    p = subprocess.Popen(
        [*exe, "serve", "../etc/loops.toml", "--no-web"],
        cwd=run,
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        first = p.stdout.readline()  # printed at start
        # stop once a sample is committed (not after a fixed sleep: on a loaded machine the
        # first cycle can come later than any sleep, and then the history is empty)
        assert wait_for_samples(run / "ctrlblocks-history.sqlite", 1, timeout=120.0)
    finally:
        p.send_signal(signal.SIGTERM)
        _rest, _ = p.communicate(timeout=30)
    assert p.returncode == 0
    assert first.strip() == f"historian: {(run / 'ctrlblocks-history.sqlite').resolve()}"
    out = subprocess.run(
        [*exe, "history", "ctrlblocks-history.sqlite", "trace.csv"],
        cwd=run, env=env, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert len((run / "trace.csv").read_text().splitlines()) >= 2


def test_vv_never_prints_the_password_asyncua_logs_in_its_identity_token():
    import io
    import logging

    from ctrlblocks.runtime.cli import SecretFilter

    out = io.StringIO()
    handler = logging.StreamHandler(out)
    handler.addFilter(SecretFilter())
    lg = logging.getLogger("asyncua.client.ua_client.test")
    lg.addHandler(handler)
    lg.setLevel(logging.DEBUG)
    try:
        # what asyncua 2.1 logs at DEBUG when it activates a session
        token = "UserNameIdentityToken(PolicyId='username', UserName='op', Password=b's3cret')"
        lg.debug("activate_session: %s", token)
        lg.debug("read_attributes of several nodes")
    finally:
        lg.removeHandler(handler)
    text = out.getvalue()
    assert "s3cret" not in text and "identity token: not shown" in text
    assert "read_attributes of several nodes" in text  # other debug lines stay


def test_v_does_not_show_the_protocol_libraries_request_lines(monkeypatch):
    """asyncua logs 'read_attributes of several nodes' and a write line at INFO: two lines
    per cycle at -v.  They show at -vv only."""
    import logging

    from ctrlblocks.runtime.cli import configure_logging

    for name in ("asyncua", "pymodbus"):
        monkeypatch.setattr(logging.getLogger(name), "level", logging.getLogger(name).level)
    configure_logging(1)
    assert not logging.getLogger("asyncua.client.ua_session").isEnabledFor(logging.INFO)
    assert not logging.getLogger("pymodbus.logging").isEnabledFor(logging.INFO)
    configure_logging(2)
    assert logging.getLogger("asyncua.client.ua_session").isEnabledFor(logging.DEBUG)
