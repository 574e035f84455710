"""The loop configuration file: what it builds, and errors that name file, key path and problem."""

from __future__ import annotations

import math

import pytest

from ctrlblocks.blocks import ADRC, PID
from ctrlblocks.runtime import RuntimeConfigError, load_config, parse_config
from ctrlblocks.runtime.modbus import float32_to_registers, registers_to_float32

CONN = """
[connections.plc]
protocol = "opcua"
url = "opc.tcp://127.0.0.1:4840"

[connections.rig]
protocol = "modbus"
port = 5020
word_order = "little"
"""

LOOP = """
[[loops]]
name = "level"
ts = 0.1
block = { type = "PID", kp = 2.0, ti = 8.0, u_min = 0.0, u_max = 100.0 }
pv = "plc:ns=2;s=pv"
mv = "plc:ns=2;s=mv"
sp = 50.0
safe_value = 5.0
"""


def test_minimal_file_builds_the_loop_with_its_safe_value():
    cfg = parse_config(CONN + LOOP)
    (lc,) = cfg.loops
    assert (lc.name, lc.ts, lc.pv.connection, lc.pv.address) == ("level", 0.1, "plc", "ns=2;s=pv")
    assert lc.sp.value == 50.0 and not lc.sp.is_io
    assert lc.mode.value == "auto"
    blk = cfg.build_blocks()["level"]
    assert isinstance(blk, PID)
    assert (blk.config.kp, blk.config.ti, blk.config.ts) == (2.0, 8.0, 0.1)
    assert blk.config.safe_value == 5.0  # on_bad_pv = "safe" (default)
    assert cfg.connections["rig"].word_order == "little"
    assert cfg.historian.backend == "sqlite"


def test_pid_hold_and_adrc_safe_value_reach_the_blocks():
    text = (
        CONN
        + LOOP.replace("safe_value = 5.0", 'safe_value = 5.0\non_bad_pv = "hold"')
        + """
[[loops]]
name = "pressure"
ts = 0.05
block = { type = "ADRC", order = 2, b0 = 0.05, omega_c = 0.35, omega_o = 1.75 }
pv = "rig:ir:0"
mv = "rig:hr:2"
sp = "rig:hr:4"
mode = "rig:hr:6"
safe_value = 1.25
"""
    )
    cfg = parse_config(text)
    blocks = cfg.build_blocks()
    assert blocks["level"].config.safe_value is None  # hold
    adrc = blocks["pressure"]
    assert isinstance(adrc, ADRC) and adrc.config.u_sf == 1.25 and adrc.config.ts == 0.05
    lc = cfg.loops[1]
    assert lc.sp.is_io and lc.mode.is_io and lc.mode.address == "hr:6"


ERRORS = [
    # (change to the minimal file, key path, words of the problem)
    (("sp = 50.0", "sp = 50.0\ncolour = 1"), "loops[0].colour", "unknown key"),
    (("safe_value = 5.0", ""), "loops[0].safe_value", "missing"),
    (("kp = 2.0", "kp = -2.0"), "loops[0].block.kp", "must be > 0"),
    (("u_min = 0.0, u_max = 100.0", "u_min = 9.0, u_max = 1.0"), "loops[0].block.u_min/u_max", ""),
    (('pv = "plc:ns=2;s=pv"', 'pv = "dcs:ns=2;s=pv"'), "loops[0].pv", "unknown connection"),
    (('pv = "plc:ns=2;s=pv"', "pv = 3.0"), "loops[0].pv", "I/O address"),
    (('type = "PID"', 'type = "LeadLag"'), "loops[0].block.type", "PID or ADRC"),
    (("ts = 0.1", "ts = 0.0"), "loops[0].ts", "> 0"),
    (('url = "opc.tcp://127.0.0.1:4840"', 'url = "http://x"'), "connections.plc.url", "opc.tcp"),
    (('word_order = "little"', 'word_order = "middle"'), "connections.rig.word_order", "big"),
    (('mv = "plc:ns=2;s=mv"', 'mv = "rig:coil:3"'), "loops[0].mv", "hr:N or ir:N"),
    (("sp = 50.0", 'sp = 50.0\nmode = "cascade"'), "loops[0].mode", "mode name"),
    (("sp = 50.0", 'sp = 50.0\non_bad_pv = "explode"'), "loops[0].on_bad_pv", "safe, hold"),
    (("ts = 0.1", "ts = 0.1\nwarn_limit = 0.3\nalarm_limit = 0.2"), "loops[0].alarm_limit", ""),
    (("sp = 50.0", 'sp = 50.0\nu_min = "plc:ns=2;s=lo"'), "loops[0].u_min", "together"),
]


@pytest.mark.parametrize(("change", "key", "words"), ERRORS)
def test_errors_name_the_file_the_key_path_and_the_problem(tmp_path, change, key, words):
    text = (CONN + LOOP).replace(*change)
    path = tmp_path / "loops.toml"
    path.write_text(text)
    with pytest.raises(RuntimeConfigError) as e:
        load_config(path)
    assert e.value.file == str(path)
    assert e.value.key == key
    assert words in e.value.problem
    assert str(e.value).startswith(f"{path}, line {e.value.line}: {key}: ")
    # the line named writes the key (a missing key: the header of its table)
    written = text.splitlines()[e.value.line - 1]
    leaf = key.split("/")[0].rsplit(".", 1)[-1]
    assert leaf in written if words != "missing" else written == "[[loops]]", written


def test_an_mv_is_written_by_one_loop_only():
    with pytest.raises(RuntimeConfigError) as e:
        parse_config(CONN + LOOP + LOOP.replace('"level"', '"level2"'))
    assert e.value.key == "loops[1].mv" and "already written by loop 'level'" in e.value.problem


def test_security_needs_the_certificates_and_a_password_from_the_environment(monkeypatch):
    secure = CONN.replace(
        'url = "opc.tcp://127.0.0.1:4840"',
        'url = "opc.tcp://127.0.0.1:4840"\nsecurity = "Basic256Sha256_SignAndEncrypt"',
    )
    with pytest.raises(RuntimeConfigError) as e:
        parse_config(secure + LOOP)
    assert e.value.key == "connections.plc.certificate"
    full = secure.replace(
        'security = "Basic256Sha256_SignAndEncrypt"',
        'security = "Basic256Sha256_SignAndEncrypt"\ncertificate = "c.der"\n'
        'private_key = "c.pem"\nserver_certificate = "s.der"\nuser = "op"\n'
        'password_env = "PLC_PASSWORD"',
    )
    monkeypatch.delenv("PLC_PASSWORD", raising=False)
    with pytest.raises(RuntimeConfigError, match="PLC_PASSWORD is not set"):
        parse_config(full + LOOP)
    monkeypatch.setenv("PLC_PASSWORD", "pw")
    c = parse_config(full + LOOP, base=__import__("pathlib").Path("/etc/ctrl")).connections["plc"]
    assert (c.user, c.password, c.certificate) == ("op", "pw", "/etc/ctrl/c.der")


def test_secrets_never_show_in_reprs_or_error_messages():
    """A password or a DSN (it may hold one) must not leak through a log line or a traceback."""
    with_user = CONN.replace(
        'url = "opc.tcp://127.0.0.1:4840"',
        'url = "opc.tcp://127.0.0.1:4840"\nuser = "op"\npassword = "s3cret-pw"',
    )
    dsn = '[historian]\nbackend = "postgresql"\ndsn = "postgresql://op:db-s3cret@db/h"\n'
    cfg = parse_config(with_user + LOOP + dsn)
    assert cfg.connections["plc"].password == "s3cret-pw"
    assert cfg.historian.dsn == "postgresql://op:db-s3cret@db/h"
    text = repr(cfg)
    assert "s3cret-pw" not in text and "db-s3cret" not in text
    with pytest.raises(RuntimeConfigError) as e:  # a password typed as a number
        parse_config(with_user.replace('"s3cret-pw"', "87654321") + LOOP)
    assert e.value.key == "connections.plc.password" and "87654321" not in str(e.value)


def test_a_password_without_security_is_warned_about_without_showing_it(caplog):
    from ctrlblocks.runtime.opcua import OpcUaAdapter

    with_user = CONN.replace(
        'url = "opc.tcp://127.0.0.1:4840"',
        'url = "opc.tcp://127.0.0.1:4840"\nuser = "op"\npassword = "s3cret-pw"',
    )
    with caplog.at_level("WARNING", logger="ctrlblocks.runtime.opcua"):
        OpcUaAdapter(parse_config(with_user + LOOP).connections["plc"])
        OpcUaAdapter(parse_config(CONN + LOOP).connections["plc"])  # no password: no warning
    (rec,) = caplog.records
    assert "connection plc: a password without security" in rec.getMessage()
    assert "s3cret-pw" not in caplog.text


def test_toml_syntax_error_gives_the_line():
    with pytest.raises(RuntimeConfigError) as e:
        parse_config("[[loops]]\nname = \n")
    assert e.value.line == 2 and "TOML syntax error" in e.value.problem


# --- Modbus FLOAT32 registers (IEEE 754 single, Modbus registers big-endian) -------------

FLOAT32 = [
    # value, high word, low word (IEEE 754 binary32, by hand)
    (1.0, 0x3F80, 0x0000),
    (-2.5, 0xC020, 0x0000),
    (0.15625, 0x3E20, 0x0000),
    (100.0, 0x42C8, 0x0000),
    (123.456, 0x42F6, 0xE979),  # nearest single: 123.45600128173828
]


@pytest.mark.parametrize(("value", "hi", "lo"), FLOAT32)
def test_float32_registers_in_both_word_orders(value, hi, lo):
    assert float32_to_registers(value, "big") == (hi, lo)
    assert float32_to_registers(value, "little") == (lo, hi)
    assert registers_to_float32([hi, lo], "big") == registers_to_float32([lo, hi], "little")
    back = registers_to_float32([hi, lo], "big")
    assert back == pytest.approx(value, rel=6e-8)


def test_float32_carries_nan_and_rounds_to_24_bits():
    assert math.isnan(registers_to_float32(float32_to_registers(math.nan)))
    assert registers_to_float32(float32_to_registers(0.1)) == 0.10000000149011612
