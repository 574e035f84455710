"""``ctrlblocks operator`` and ``ctrlblocks serve`` (the web module's command)."""

from __future__ import annotations

import json

from click.testing import CliRunner

from ctrlblocks.cli import main
from ctrlblocks.web.cli import serve


def test_operator_add_list_remove(tmp_path, monkeypatch):
    users = tmp_path / "users.json"
    monkeypatch.setenv("OP_PW", "a long password")
    r = CliRunner().invoke(
        main, ["operator", "add", "alice", "--users", str(users), "--password-env", "OP_PW"]
    )
    assert r.exit_code == 0, r.output
    assert "a long password" not in users.read_text()
    assert list(json.loads(users.read_text())["users"]) == ["alice"]
    r = CliRunner().invoke(main, ["operator", "list", "--users", str(users)])
    assert r.output.split() == ["alice", "operator"]  # the default role
    r = CliRunner().invoke(main, ["operator", "remove", "alice", "--users", str(users)])
    assert r.exit_code == 0
    r = CliRunner().invoke(main, ["operator", "remove", "alice", "--users", str(users)])
    assert r.exit_code != 0 and "no user 'alice'" in r.output


def test_operator_add_asks_twice_for_the_password_and_refuses_short_ones(tmp_path):
    users = tmp_path / "users.json"
    r = CliRunner().invoke(
        main,
        ["operator", "add", "bob", "--users", str(users)],
        input="a long password\na long password\n",
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(
        main, ["operator", "add", "eve", "--users", str(users)], input="short\nshort\n"
    )
    assert r.exit_code != 0 and "at least 8 characters" in r.output


def test_serve_without_config_checks_the_demo(tmp_path):
    r = CliRunner().invoke(serve, ["--check", "--users", str(tmp_path / "u.json")])
    assert r.exit_code == 0, r.output
    assert "demo: 2 loop(s): OK" in r.output


def test_serve_check_of_a_config_is_the_runtimes_check(tmp_path):
    cfg = tmp_path / "loops.toml"
    cfg.write_text(
        '[connections.sim]\nprotocol = "memory"\n\n[[loops]]\nname = "a"\nts = 0.1\n'
        'block = { type = "PID", kp = 1.0, ti = 1.0 }\npv = "sim:pv"\nmv = "sim:mv"\n'
        "sp = 0.0\nsafe_value = 0.0\n"
    )
    r = CliRunner().invoke(serve, [str(cfg), "--check"])
    assert r.exit_code == 0, r.output
    assert "1 loop(s), 1 connection(s): OK" in r.output


def test_serve_demo_in_one_command_shows_the_faceplate_and_stops_on_sigint(tmp_path):
    import signal
    import socket
    import subprocess
    import sys
    import threading

    import httpx2 as httpx

    with socket.socket() as s:  # a free port on the loopback interface
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    cmd = [sys.executable, "-m", "ctrlblocks.web", "--port", str(port), "-v"]
    cmd += ["--users", str(tmp_path / "u.json"), "--history", str(tmp_path / "h.sqlite")]
    # stdout to a file and stderr drained by a thread: a pipe nobody reads fills up
    # and blocks the server (its -v log and the access log go on while the test runs)
    out_file = open(tmp_path / "out.txt", "w")  # noqa: SIM115 - closed in finally
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=out_file, stderr=subprocess.PIPE, text=True)
    err_lines: list[str] = []
    listening = threading.Event()

    def drain_stderr() -> None:
        for line in proc.stderr:
            err_lines.append(line)
            if "Application startup complete" in line:  # uvicorn logs this once it listens
                listening.set()
        listening.set()  # the process ended

    drainer = threading.Thread(target=drain_stderr, daemon=True)
    drainer.start()
    watchdog = threading.Timer(60.0, proc.kill)  # a hung server fails the test, not the run
    watchdog.start()
    try:
        listening.wait(90.0)
        info = httpx.get(f"http://127.0.0.1:{port}/api/info", timeout=30).json()
        # the demo is public: anyone watches without a login
        assert info["loops"] == ["pressure", "flow"] and info["role"] is None
        page = httpx.get(f"http://127.0.0.1:{port}/", timeout=30)
        assert "uPlot" in page.text
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
        drainer.join(timeout=30)
        watchdog.cancel()
        out_file.close()
    out, err = (tmp_path / "out.txt").read_text(), "".join(err_lines)
    assert proc.returncode == 0, err
    assert f"faceplate: http://127.0.0.1:{port}/" in out
    assert "no operators" in out
    assert "runtime ctrlblocks demo: stopped" in err  # graceful stop: safe values, flush
    assert (tmp_path / "h.sqlite").exists()


def test_docs_page_shows_the_screenshot_and_its_error_example_is_the_blocks_code():
    from pathlib import Path

    from ctrlblocks.blocks.base import ErrorCode

    docs = Path(__file__).resolve().parents[2] / "docs"
    text = (docs / "faceplate.md").read_text(encoding="utf-8")
    assert "](figures/faceplate.png)" in text
    assert (docs / "figures" / "faceplate.png").read_bytes()[:4] == b"\x89PNG"
    code = ErrorCode.BAD_B0
    assert f'"code":{int(code)},"code_hex":"16#{int(code):04X}","name":"{code.name}"' in text


def test_operator_roles_and_disable_from_the_command_line(tmp_path, monkeypatch):
    users = str(tmp_path / "users.json")
    monkeypatch.setenv("PW", "a long password")
    run = CliRunner().invoke
    for name, role in (("eve", "engineer"), ("val", "viewer")):
        r = run(
            main,
            ["operator", "add", name, "--users", users, "--password-env", "PW", "--role", role],
        )
        assert r.exit_code == 0 and f"{role} {name!r} saved" in r.output, r.output
    r = run(
        main, ["operator", "add", "x", "--users", users, "--password-env", "PW", "--role", "root"]
    )
    assert r.exit_code != 0 and "root" in r.output
    assert run(main, ["operator", "disable", "val", "--users", users]).exit_code == 0
    r = run(main, ["operator", "list", "--users", users])
    assert r.output.splitlines() == ["eve engineer", "val viewer disabled"]
    assert run(main, ["operator", "disable", "val", "--enable", "--users", users]).exit_code == 0
    assert run(main, ["operator", "list", "--users", users]).output.splitlines()[1] == "val viewer"
    r = run(main, ["operator", "disable", "nobody", "--users", users])
    assert r.exit_code != 0 and "no user 'nobody'" in r.output


def test_serve_needs_certfile_and_keyfile_together(tmp_path):
    cert = tmp_path / "cert.pem"
    cert.write_text("not used")
    r = CliRunner().invoke(serve, ["--certfile", str(cert), "--users", str(tmp_path / "u.json")])
    assert r.exit_code == 2 and "--certfile and --keyfile together" in r.output
