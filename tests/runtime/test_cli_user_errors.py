"""Every user mistake at the start of a runtime-facing command: one line, exit code, no traceback.

``serve`` (with and without the faceplate, with a file and the demo),
``plant-server``, ``history``, ``operator`` and ``tune-live``.  Each case
builds its files in ``tmp_path``, runs the command (in a process of its own
when it starts a server, so what uvicorn or the logging prints is seen too;
else with click's runner), and checks the exit code, that no traceback shows,
that the message names the file, line, key or port, and that a DSN's
password never shows.  The commands that used to hang (a retain file that
cannot be written, a plant server with both ports off) run with a generous
timeout: a hang fails the test, it does not block the run.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner

from ctrlblocks.cli import main

from .conftest import DATA, loop_toml

SECRET = "s3cretpw"
DSN = f"postgresql://ctrl:{SECRET}@127.0.0.1:{{port}}/plant"
"""A DSN with a password, on a port where nothing listens (the test binds it, no listen)."""

GOOD = '[connections.io]\nprotocol = "memory"\n' + loop_toml(ts=0.1)
NO_RETAIN = "\n[retain]\nenabled = false\n"


@dataclasses.dataclass
class Case:
    """``args(tmp_path)`` -> the command line; what its output must (not) hold."""

    args: Callable[[Path], list[str]]
    code: int
    says: Callable[[Path], list[str]]
    process: bool = False  # run in a process of its own (it would start a server)
    not_made: tuple[str, ...] = ()  # files that must not exist afterwards (nothing started)


def write(path: Path, text: str | bytes) -> str:
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return str(path)


def free_port() -> int:
    """A port nothing listens on (bound and closed again)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def historian(where: str) -> str:
    return GOOD + f'\n[historian]\npath = "{where}"\n' + NO_RETAIN


def postgres(port: int) -> str:
    return GOOD + f'\n[historian]\nbackend = "postgresql"\ndsn = "{DSN.format(port=port)}"\n'


def missing_folder(tmp: Path) -> str:
    return str(tmp / "no such folder" / "h.sqlite")


PEM = b"-----BEGIN CERTIFICATE-----\nnot base64 at all\n-----END CERTIFICATE-----\n"
TYPO = GOOD.replace("sp = 1.0", "sp = 1.0\nspx = 2.0")  # line 11 of the file
TYPO_LINE = TYPO.splitlines().index("spx = 2.0") + 1
SCENARIO_TYPO = (DATA / "pid_pt2.toml").read_text().replace("[plant]", "[plant]\nbogus = 1", 1)
SCENARIO_TYPO_LINE = SCENARIO_TYPO.splitlines().index("bogus = 1") + 1


def serve(tmp: Path, text: str, *extra: str) -> list[str]:
    return ["serve", write(tmp / "loops.toml", text), "--port", str(free_port()), *extra]


CASES: dict[str, Case] = {
    # -- serve: the file ------------------------------------------------------------------
    "serve: a file that does not exist": Case(
        lambda t: ["serve", str(t / "nope.toml")], 2, lambda t: ["nope.toml", "does not exist"]
    ),
    "serve: a file that is not UTF-8 (web)": Case(
        lambda t: serve(t, b'[connections.io]\nprotocol = "memory"\n# caf\xe9\n'),
        1,
        lambda t: [f"{t / 'loops.toml'}, line 3: not a UTF-8 text file (byte 0xe9)"],
        process=True,
    ),
    "serve --check: a file that is not UTF-8": Case(
        lambda t: serve(t, b"\xff\xfe[[loops]]\n", "--check"),
        1,
        lambda t: [f"{t / 'loops.toml'}, line 1: not a UTF-8 text file (byte 0xff)"],
    ),
    "serve: a TOML syntax error": Case(
        lambda t: serve(t, GOOD.replace("sp = 1.0", "sp = = 1.0"), "--no-web"),
        1,
        lambda t: [f"{t / 'loops.toml'}, line {TYPO_LINE - 1}: TOML syntax error"],
    ),
    "serve: an unknown key names file, line and key path (web)": Case(
        lambda t: serve(t, TYPO),
        1,
        lambda t: [f"{t / 'loops.toml'}, line {TYPO_LINE}: loops[0].spx: unknown key 'spx'"],
        process=True,
    ),
    # -- serve: the historian and the retain file -------------------------------------------
    "serve: a historian in a folder that does not exist (web)": Case(
        lambda t: serve(t, historian(missing_folder(t))),
        1,
        lambda t: [f"historian: {missing_folder(t)}: OperationalError: unable to open database"],
        process=True,
    ),
    "serve --no-web: a historian in a folder that does not exist": Case(
        lambda t: serve(t, historian(missing_folder(t)), "--no-web"),
        1,
        lambda t: [f"historian: {missing_folder(t)}: OperationalError: unable to open database"],
        process=True,
    ),
    "serve (the demo): --history in a folder that does not exist": Case(
        lambda t: ["serve", "--port", str(free_port()), "--history", missing_folder(t),
                   "--users", str(t / "u.json")],
        1,
        lambda t: [f"historian: {missing_folder(t)}: OperationalError: unable to open database"],
        process=True,
    ),
    "serve: a PostgreSQL historian that does not answer (web)": Case(
        lambda t: serve(t, postgres(free_port()) + NO_RETAIN),
        1,
        lambda t: ["historian: PostgreSQL: OperationalError: connection failed",
                   "Connection refused; Is the server running"],
        process=True,
    ),
    "serve --no-web: a PostgreSQL historian that does not answer": Case(
        lambda t: serve(t, postgres(free_port()) + NO_RETAIN, "--no-web"),
        1,
        lambda t: ["historian: PostgreSQL: OperationalError: connection failed",
                   "Connection refused; Is the server running"],
        process=True,
    ),
    "serve --no-web: a retain file that cannot be written": Case(
        lambda t: serve(
            t, GOOD + f'\n[retain]\npath = "{t / "no such folder" / "r.sqlite"}"\n', "--no-web"
        ),
        1,
        lambda t: [f"retain.path: {t / 'no such folder' / 'r.sqlite'}: cannot write it"],
        process=True,
    ),
    "serve: a retain file that cannot be written (web)": Case(
        lambda t: serve(t, GOOD + f'\n[retain]\npath = "{t / "no such folder" / "r.sqlite"}"\n'),
        1,
        lambda t: [f"retain.path: {t / 'no such folder' / 'r.sqlite'}: cannot write it"],
        process=True,
    ),
    # -- serve: the faceplate's port and TLS files ------------------------------------------
    "serve: --certfile that does not exist": Case(
        lambda t: serve(t, GOOD, "--certfile", str(t / "c.pem"), "--keyfile", str(t / "c.pem")),
        2,
        lambda t: ["--certfile", "c.pem", "does not exist"],
    ),
    "serve: --keyfile without --certfile": Case(
        lambda t: serve(t, GOOD, "--keyfile", write(t / "k.pem", PEM)),
        2,
        lambda t: ["give --certfile and --keyfile together"],
    ),
    "serve: --certfile/--keyfile that are not PEM": Case(
        lambda t: serve(t, historian(str(t / "h.sqlite")), "--certfile", write(t / "c.pem", PEM),
                        "--keyfile", str(t / "c.pem")),
        1,
        lambda t: [f"--certfile {t / 'c.pem'} / --keyfile {t / 'c.pem'}: not a TLS certificate"],
        process=True,
        not_made=("h.sqlite",),
    ),
    # -- plant-server -------------------------------------------------------------------------
    "plant-server: an unknown key names file, line and key path": Case(
        lambda t: ["plant-server", write(t / "sc.toml", SCENARIO_TYPO), "--opcua-port", "0"],
        1,
        lambda t: [f"{t / 'sc.toml'}, line {SCENARIO_TYPO_LINE}: plant.bogus: unknown key"],
    ),
    "plant-server: a scenario that is not UTF-8": Case(
        lambda t: ["plant-server", write(t / "sc.toml", b"[plant]\n# \xff\n"), "--opcua-port", "0"],
        1,
        lambda t: [f"{t / 'sc.toml'}, line 2: not a UTF-8 text file"],
    ),
    "plant-server: a --case the scenario does not have": Case(
        lambda t: ["plant-server", str(DATA / "pid_pt2.toml"), "--case", "nope",
                   "--opcua-port", "0", "--modbus-port", str(free_port())],
        2,
        lambda t: ["--case", "has no case 'nope'; its cases: "],
    ),
    "plant-server: both ports off": Case(
        lambda t: ["plant-server", str(DATA / "pid_pt2.toml"), "--opcua-port", "0",
                   "--modbus-port", "0"],
        2,
        lambda t: ["nothing to serve: --opcua-port and --modbus-port are both 0"],
        process=True,
    ),
    "plant-server: a --certificate that is not a certificate": Case(
        lambda t: ["plant-server", str(DATA / "pid_pt2.toml"), "--modbus-port", "0",
                   "--opcua-port", str(free_port()), "--certificate", write(t / "c.pem", PEM),
                   "--private-key", str(t / "c.pem"), "--user", "op:pw"],
        1,
        lambda t: [f"{t / 'c.pem'}: not an OPC UA server certificate"],
        process=True,
    ),
    # -- history ------------------------------------------------------------------------------
    "history: a file that does not exist": Case(
        lambda t: ["history", str(t / "h.sqlite"), str(t / "out.csv")],
        1,
        lambda t: [f"{t / 'h.sqlite'}: no such historian database"],
        not_made=("h.sqlite", "out.csv"),
    ),
    "history: a file that is not a historian": Case(
        lambda t: ["history", write(t / "h.sqlite", "hello\n"), str(t / "out.csv")],
        1,
        lambda t: [f"{t / 'h.sqlite'}: not a historian database"],
        not_made=("out.csv",),
    ),
    "history --postgres: a server that does not answer": Case(
        lambda t: ["history", DSN.format(port=free_port()), str(t / "o.csv"), "--postgres"],
        1,
        lambda t: ["PostgreSQL: OperationalError: connection failed", "Connection refused"],
        not_made=("o.csv",),
    ),
    "history --postgres: a DSN that does not parse": Case(
        lambda t: ["history", f"postgresql://ctrl:{SECRET}%zz@127.0.0.1/db", str(t / "o.csv"),
                   "--postgres"],
        1,
        lambda t: ["PostgreSQL: ProgrammingError: invalid percent-encoded token"],
    ),
    "history: a DSN without --postgres": Case(
        lambda t: ["history", DSN.format(port=free_port()), str(t / "o.csv")],
        1,
        lambda t: ["looks like a PostgreSQL DSN, not a file: add --postgres"],
    ),
    # -- operator -----------------------------------------------------------------------------
    "operator list: a users file that does not exist": Case(
        lambda t: ["operator", "list", "--users", str(t / "users.json")],
        1,
        lambda t: [f"{t / 'users.json'}: no such users file"],
        not_made=("users.json",),
    ),
    "operator disable: a users file that does not exist": Case(
        lambda t: ["operator", "disable", "bob", "--users", str(t / "users.json")],
        1,
        lambda t: [f"{t / 'users.json'}: no such users file"],
        not_made=("users.json",),
    ),
    "operator list: a users file that is not JSON": Case(
        lambda t: ["operator", "list", "--users", write(t / "users.json", "{bad")],
        1,
        lambda t: [f"{t / 'users.json'}: ", "line 1 column 2"],
    ),
    # -- tune-live (without a faceplate; the unknown loop: below) ---------------------------
    "tune-live: a --cafile that is not a certificate": Case(
        lambda t: ["tune-live", "--loop", "x", "--status", "--url", "https://127.0.0.1:1/",
                   "--cafile", write(t / "ca.pem", PEM)],
        1,
        lambda t: [f"--cafile: {t / 'ca.pem'}: not a certificate in PEM"],
    ),
    "tune-live: no faceplate at --url": Case(
        lambda t: ["tune-live", "--loop", "x", "--status", "--url",
                   f"http://127.0.0.1:{free_port()}/"],
        1,
        lambda t: ["cannot reach the faceplate at http://127.0.0.1:"],
    ),
}


def run(args: list[str], cwd: Path, process: bool) -> tuple[int, str]:
    """Exit code and everything printed (stdout and stderr)."""
    if not process:
        r = CliRunner().invoke(main, args)
        assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
        return r.exit_code, r.output
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    p = subprocess.run(
        [sys.executable, "-c", "from ctrlblocks.cli import main; main()", *args],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    return p.returncode, p.stdout + p.stderr


@pytest.mark.parametrize("name", list(CASES))
def test_a_user_mistake_is_one_line_with_an_exit_code(tmp_path, name):
    case = CASES[name]
    code, out = run(case.args(tmp_path), tmp_path, case.process)
    assert code == case.code, out
    assert "Traceback" not in out and "File \"" not in out, out
    assert SECRET not in out
    error = [line for line in out.splitlines() if line.startswith("Error: ")]
    assert len(error) == 1, out  # one error line, which holds the whole message
    for words in case.says(tmp_path):
        assert words in error[0], out
    for made in case.not_made:
        assert not (tmp_path / made).exists(), f"{made} was made: {out}"


@pytest.mark.parametrize("web", [True, False])
def test_a_busy_faceplate_port_is_refused_before_any_loop_starts(tmp_path, web):
    """The port is bound before the runtime starts: no historian run, no MV written."""
    cfg = write(tmp_path / "loops.toml", historian(str(tmp_path / "h.sqlite")))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        args = ["serve", cfg] if web else ["serve", "--history", str(tmp_path / "h.sqlite")]
        code, out = run([*args, "--port", str(port)], tmp_path, True)
    assert code == 1 and "Traceback" not in out, out
    assert f"Error: cannot listen on 127.0.0.1:{port}: Address already in use" in out
    assert "choose another port with --port" in out
    assert not (tmp_path / "h.sqlite").exists(), out  # nothing started


def test_tune_live_of_an_unknown_loop_names_it(tmp_path):
    pytest.importorskip("fastapi")
    from tests.web.conftest import OPERATOR, make_runtime, make_users, running_server

    with running_server(make_runtime(tmp_path), make_users(tmp_path)) as url:
        r = CliRunner().invoke(
            main,
            ["tune-live", "--url", url, "--loop", "nope", "--user", OPERATOR[0],
             "--password-env", "PW", "--method", "step", "--amplitude", "0.5"],
            env={"PW": OPERATOR[1]},
        )  # fmt: skip
    assert r.exit_code == 1 and (r.exception is None or isinstance(r.exception, SystemExit))
    assert r.output.strip() == "Error: loop: unknown loop 'nope'"


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads every file")
def test_an_unreadable_file_is_named(tmp_path):
    cfg = tmp_path / "loops.toml"
    cfg.write_text(GOOD)
    cfg.chmod(0)
    code, out = run(["serve", str(cfg), "--check"], tmp_path, False)
    assert code == 1 and f"{cfg}: cannot read the file (Permission denied)" in out


def test_a_dsn_password_is_hidden_in_every_form():
    from ctrlblocks.runtime.historian import hide_dsn_secrets

    for dsn, pw in [
        ("postgresql://u:p%40ss@h/db", "p@ss"),
        ("host=h password='two words' user=u", "two words"),
        ("host=h password=plain user=u", "plain"),
        ("postgresql://u@h/db?password=inquery&sslmode=disable", "inquery"),
        # what the driver itself reads as the secret: an escaped quote inside a quoted
        # value, a percent-encoded query value, the SSL key's password, spaces around "="
        ("host=h password='it\\'s secret' user=u", "it's secret"),
        ("postgresql://u@h/db?password=p%26q", "p&q"),
        ("host=h sslpassword=keypass", "keypass"),
        ("postgresql://h/db?sslpassword=k%20p", "k p"),
        ("host=h password = spaced", "spaced"),
    ]:
        text = hide_dsn_secrets(f"bad {dsn}\nsecond line {pw}", dsn)
        assert pw not in text and "\n" not in text and "second line ***" in text, (dsn, text)


def test_a_dsn_the_driver_cannot_parse_still_has_its_password_hidden():
    from ctrlblocks.runtime.historian import hide_dsn_secrets

    dsn = "host=h password='unterminated"  # the driver refuses it and may quote it back
    text = hide_dsn_secrets(f"invalid dsn: {dsn}", dsn)
    assert "unterminated" not in text
