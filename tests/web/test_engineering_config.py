"""The loop keys of the faceplate in the runtime's TOML: units, engineering ranges, ``[web]``."""

from __future__ import annotations

import pytest

from ctrlblocks.runtime import RuntimeConfigError, parse_config

BASE = """
[connections.sim]
protocol = "memory"

[[loops]]
name = "a"
ts = 0.1
block = { type = "PID", kp = 1.0, ti = 1.0, u_min = 0.0, u_max = 10.0 }
pv = "sim:pv"
mv = "sim:mv"
sp = 1.0
safe_value = 0.0
"""


def parse(extra_loop: str = "", tail: str = ""):
    return parse_config(BASE + extra_loop + tail, file="loops.toml")


def test_without_the_keys_there_are_no_ranges_no_units_and_no_public_view():
    cfg = parse()
    lc = cfg.loops[0]
    assert (lc.sp_range, lc.mv_range, dict(lc.tuning_ranges)) == (None, None, {})
    assert dict(lc.units) == {"pv": "", "sp": "", "mv": ""}
    assert (cfg.web.public_view, cfg.web.confirm_step) == (False, 0.1)


def test_units_ranges_and_web_are_read():
    cfg = parse(
        'unit = { pv = "bar", mv = "%" }\nsp_range = [0, 3]\nmv_range = [0.0, 8.0]\n'
        "tuning_ranges = { kp = [0.1, 5], ti = [0.5, 100.0] }\n",
        "\n[web]\npublic_view = true\nconfirm_step = 0.25\n",
    )
    lc = cfg.loops[0]
    assert dict(lc.units) == {"pv": "bar", "sp": "bar", "mv": "%"}  # sp: the PV's unit
    assert (lc.sp_range, lc.mv_range) == ((0.0, 3.0), (0.0, 8.0))
    assert dict(lc.tuning_ranges) == {"kp": (0.1, 5.0), "ti": (0.5, 100.0)}
    assert (cfg.web.public_view, cfg.web.confirm_step) == (True, 0.25)
    assert dict(parse('unit = "%"\n').loops[0].units) == {"pv": "%", "sp": "%", "mv": ""}


@pytest.mark.parametrize(
    ("extra", "tail", "key", "problem"),
    [
        ("sp_range = [3, 0]\n", "", "loops[0].sp_range", "below high"),
        ("sp_range = [0, inf]\n", "", "loops[0].sp_range", "two finite numbers"),
        ("mv_range = [0]\n", "", "loops[0].mv_range", "two finite numbers"),
        ("sp_range = [2, 3]\n", "", "loops[0].sp", "outside [2.0, 3.0]"),
        ("tuning_ranges = { kq = [0, 1] }\n", "", "loops[0].tuning_ranges.kq", "not a tuning"),
        (
            "tuning_ranges = { kp = [2, 3] }\n",
            "",
            "loops[0].tuning_ranges.kp",
            "kp = 1.0 is outside",
        ),
        ("tuning_ranges = { form = [0, 1] }\n", "", "loops[0].tuning_ranges.form", "not a number"),
        ('unit = { pv = "' + "x" * 17 + '" }\n', "", "loops[0].unit.pv", "at most 16"),
        ('unit = { qv = "bar" }\n', "", "loops[0].unit.qv", "unknown key"),
        ("", '\n[web]\npublic_view = "yes"\n', "web.public_view", "true or false"),
        ("", "\n[web]\nconfirm_step = 2.0\n", "web.confirm_step", "(0, 1]"),
        ("", "\n[web]\nport = 80\n", "web.port", "unknown key"),
    ],
)
def test_bad_keys_are_refused_with_the_file_and_key_path(extra, tail, key, problem):
    with pytest.raises(RuntimeConfigError) as exc:
        parse(extra, tail)
    assert exc.value.key == key and problem in exc.value.problem
    assert str(exc.value).startswith(f"loops.toml, line {exc.value.line}: {key}: ")
    # the line named is the one that writes the key (its first part inside the table)
    written = (BASE + extra + tail).splitlines()[exc.value.line - 1]
    first = key.split("].")[-1].split(".")[0] if "]" in key else key.split(".")[1]
    assert written.startswith(f"{first} = "), (written, key)
