"""The alarms' states as variables of the loop: ``alarm_outputs``, written with the MV.

End to end on 127.0.0.1 (OPC UA and Modbus TCP, the plant server's device
outputs) on the injectable clock, one cycle at a time: a PV that crosses the
H limit sets the device's H state, active and unacknowledged variables; an
acknowledgement changes the state; the return to normal clears them.  And the
configuration errors of the table, each naming file, line and key.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from ctrlblocks.runtime import (
    FakeClock,
    PlantServer,
    Runtime,
    RuntimeConfigError,
    load_config,
    parse_config,
)
from ctrlblocks.runtime.health import ALARM_OUTPUT_KEYS
from ctrlblocks.runtime.plant_server import MODBUS_REGISTERS

from .conftest import bounded, loop_toml, wait_for

TS = 0.1
ALARMS = "alarms = { h = 80.0, hh = 90.0, deadband = 2.0 }"

# device outputs: OPC UA data types as a PLC would declare them
OUTPUTS = {
    "H_state": "UInt16",
    "H_active": "Boolean",
    "H_unack": "Boolean",
    "HH_state": "Double",
    "n_unack": "UInt16",
}
BINDS = {
    "h_state": "H_state",
    "h_active": "H_active",
    "h_unack": "H_unack",
    "hh_state": "HH_state",
    "unacknowledged": "n_unack",
}


class Level:
    """A device PV the test sets; each MV write is one sample (the plant server's lock-step)."""

    ts = TS
    sensor_ok = sensor2_ok = True

    def __init__(self) -> None:
        self.pv, self.mv, self.k = 50.0, 0.0, 0

    def values(self) -> dict[str, float]:
        nan = math.nan
        return {"pv": self.pv, "mv": self.mv, "sp": 50.0, "mode": 0.0, "manual_value": nan,
                "u_min": nan, "u_max": nan, "k": float(self.k)}  # fmt: skip

    def step(self, u: float) -> None:
        self.mv = u
        self.k += 1


def _config(conn: str, addr) -> str:
    binds = ", ".join(f'{k} = "plant:{addr(v)}"' for k, v in BINDS.items())
    return f"""
[connections.plant]
{conn}
timeout = 5.0
deadline = 5.0
[[loops]]
name = "level"
ts = {TS}
block = {{ type = "PID", kp = 0.1, ti = 10.0, u_min = 0.0, u_max = 100.0 }}
pv = "plant:{addr("pv")}"
mv = "plant:{addr("mv")}"
sp = 50.0
safe_value = 0.0
warn_limit = 5.0
alarm_limit = 10.0
{ALARMS}
alarm_outputs = {{ {binds} }}
[historian]
backend = "none"
"""


@pytest.mark.loopback
@pytest.mark.timeout(180)
@pytest.mark.parametrize("protocol", ["opcua", "modbus"])
def test_the_device_reads_the_alarm_states_of_the_loop(protocol: str) -> None:
    process = Level()
    on_opcua = protocol == "opcua"
    server = PlantServer(process, opcua_port=0 if on_opcua else None,
                         modbus_port=None if on_opcua else 0, outputs=OUTPUTS)  # fmt: skip
    clock = FakeClock(settle_steps=5)  # the test waits for each cycle's writes itself
    out = server.outputs
    refused: list[str | None] = []

    async def cycles(n: int) -> dict[str, float]:
        """Run ``n`` cycles, each once its writes reached the device; the device's outputs."""
        for _ in range(n):
            k0, w0 = process.k, len(out["n_unack"])
            await clock.run_until((round(clock.now() / TS) + 1) * TS)
            await wait_for(lambda k0=k0, w0=w0: process.k > k0 and len(out["n_unack"]) > w0
                           and clock.sleepers > 0, timeout=30.0, step=0.001)  # fmt: skip
        return {name: values[-1] for name, values in out.items()}

    async def main() -> list[dict[str, float]]:
        await server.start()
        try:
            if on_opcua:
                conn = f'protocol = "opcua"\nurl = "{server.opcua_url}"'
                text = _config(conn, lambda n: f"ns=2;s={n}")
            else:
                conn = f'protocol = "modbus"\nhost = "127.0.0.1"\nport = {server.modbus_port}'
                regs = {**MODBUS_REGISTERS, **{n: server.output_register(n) for n in OUTPUTS}}
                text = _config(conn, lambda n: f"hr:{regs[n]}")
            rt = Runtime(parse_config(text), clock=clock, retain=None)
            await rt.start()
            assert all(c.connected for c in rt.connections.values())
            seen = [await cycles(3)]  # normal
            process.pv = 85.0  # above H (80): active from this sample on
            seen.append(await cycles(2))
            rt.health.acknowledge("level", "H", user="anna")
            seen.append(await cycles(1))  # acknowledged, still active
            process.pv = 79.0  # inside the deadband (80 - 2): still active
            seen.append(await cycles(2))
            process.pv = 70.0  # returned
            seen.append(await cycles(2))
            process.pv = 85.0  # again, and back without an acknowledgement
            seen.append(await cycles(2))
            process.pv = 70.0
            seen.append(await cycles(2))
            rt.health.acknowledge("level", None, user="anna")
            seen.append(await cycles(1))
            if on_opcua:  # a Boolean variable takes 0 or 1 only, never a rounded value
                refused.extend(await rt.connections["plant"].write([("ns=2;s=H_active", 0.5)]))
            await rt.stop()
            return seen
        finally:
            await server.stop()

    seen = bounded(main(), 150.0)
    cols = ("H_state", "H_active", "H_unack", "HH_state", "n_unack")
    got = [tuple(s[c] for c in cols) for s in seen]
    assert got == [
        (0, 0, 0, 0, 0),  # NORMAL
        (1, 1, 1, 0, 1),  # UNACK: active, unacknowledged
        (2, 1, 0, 0, 0),  # ACKED
        (2, 1, 0, 0, 0),  # the deadband holds it
        (0, 0, 0, 0, 0),  # returned after the acknowledgement: NORMAL
        (1, 1, 1, 0, 1),  # UNACK again
        (3, 0, 1, 0, 1),  # RTN_UNACK: returned, still to acknowledge
        (0, 0, 0, 0, 0),  # acknowledged: NORMAL
    ]
    # every cycle wrote every alarm output, and the state went through the ISA-18.2 states
    assert len({len(v) for v in out.values()}) == 1 and len(out["H_state"]) >= 15
    changes = [v for i, v in enumerate(out["H_state"]) if i == 0 or v != out["H_state"][i - 1]]
    assert changes == [0, 1, 2, 0, 1, 3, 0]
    if on_opcua:
        assert refused and refused[0] is not None and "Boolean" in refused[0]


def _conf(extra: str, *, second: str = "") -> str:
    return (
        '[connections.io]\nprotocol = "memory"\n[connections.mb]\nprotocol = "modbus"\n'
        + loop_toml(extra=extra)
        + second
        + '\n[historian]\nbackend = "none"\n'
    )


@pytest.mark.parametrize(
    ("extra", "key", "problem"),
    [
        ('alarm_outputs = { h_state = "io:hs" }', "alarm_outputs.h_state", "no alarms table"),
        (f'{ALARMS}\nalarm_outputs = {{ ll_state = "io:x" }}', "alarm_outputs.ll_state",
         "alarm LL is not configured (it needs alarms.ll)"),
        (f'{ALARMS}\nalarm_outputs = {{ h_flag = "io:x" }}', "alarm_outputs.h_flag",
         "unknown key"),
        (f'{ALARMS}\nalarm_outputs = {{ h_state = 1.0 }}', "alarm_outputs.h_state",
         'must be an I/O address "CONNECTION:ADDRESS"'),
        (f'{ALARMS}\nalarm_outputs = {{ h_state = "mb:hr:0" }}', "alarm_outputs.h_state",
         "must be on the connection of mv"),
        (f'{ALARMS}\nalarm_outputs = {{ h_state = "io:pv" }}', "alarm_outputs.h_state",
         "is the address of pv"),
        (f'{ALARMS}\nalarm_outputs = {{ h_state = "io:a", hh_state = "io:a" }}',
         "alarm_outputs.hh_state", "is the address of h_state"),
        (f'{ALARMS}\nalarm_outputs = "io:a"', "alarm_outputs", "must be a table"),
        (f"{ALARMS}\nalarm_outputs = {{}}", "alarm_outputs", "is empty"),
        (f'{ALARMS[:-2]}, bad_pv = false }}\nalarm_outputs = {{ bad_state = "io:b" }}',
         "alarm_outputs.bad_state", "alarm BAD is not configured (it needs bad_pv = true)"),
    ],
)  # fmt: skip
def test_a_bad_alarm_outputs_table_names_file_line_and_key(extra, key, problem, tmp_path):
    path = tmp_path / "loops.toml"
    text = _conf(extra)
    path.write_text(text)
    with pytest.raises(RuntimeConfigError) as e:
        load_config(path)
    err = e.value
    assert err.key == f"loops[0].{key}" and problem in err.problem, str(err)
    assert Path(err.file) == path
    line = next(i for i, s in enumerate(text.splitlines(), 1) if s.startswith("alarm_outputs"))
    assert err.line == line, str(err)


def test_an_alarm_output_on_a_read_only_modbus_register_or_another_loops_address_is_refused():
    mb = loop_toml(
        conn="mb",
        pv="hr:0",
        mv="hr:2",
        extra=f'{ALARMS}\nalarm_outputs = {{ h_state = "mb:ir:10" }}',
    )
    text = '[connections.mb]\nprotocol = "modbus"\n' + mb + '\n[historian]\nbackend = "none"\n'
    with pytest.raises(
        RuntimeConfigError, match=r"alarm_outputs.h_state: must be a holding register"
    ):
        parse_config(text)
    first = loop_toml(extra=f'{ALARMS}\nalarm_outputs = {{ h_state = "io:shared" }}')
    second = loop_toml(name="other", pv="pv2", mv="shared")
    with pytest.raises(RuntimeConfigError) as e:
        parse_config('[connections.io]\nprotocol = "memory"\n' + first + second
                     + '\n[historian]\nbackend = "none"\n')  # fmt: skip
    assert "already written by loop" in str(e.value)


def test_the_alarm_output_keys_are_the_documented_ones():
    # docs/health.md and docs/runtime.md list them: the same names, in this order
    assert ALARM_OUTPUT_KEYS[:3] == ("hh_state", "hh_active", "hh_unack")
    assert ALARM_OUTPUT_KEYS[-2:] == ("unacknowledged", "worst")
    assert len(ALARM_OUTPUT_KEYS) == 7 * 3 + 2
