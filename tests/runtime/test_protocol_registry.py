"""The I/O protocol registry: a new protocol is one registration, nothing else changes."""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import pytest

from ctrlblocks.runtime import Runtime, parse_config
from ctrlblocks.runtime.config import PROTOCOLS, Protocol, RuntimeConfigError, register_protocol
from ctrlblocks.runtime.io import Adapter, Reading

from .conftest import FakeClock, bounded


class EchoAdapter(Adapter):
    """A device whose every register reads ``gain`` times the last value written to it."""

    instances: ClassVar[list[EchoAdapter]] = []

    def __init__(self, config) -> None:
        self.config = config
        self.gain = float(config.options["gain"])
        self.values: dict[str, float] = {"pv": 0.0}
        EchoAdapter.instances.append(self)

    async def connect(self) -> None:
        pass

    async def close(self) -> None:
        pass

    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        return [Reading(self.values.get(a, 0.0), True) for a in addresses]

    async def write(self, items: Sequence[tuple[str, float]]) -> list[str | None]:
        for a, v in items:
            self.values[a] = v
            self.values["pv"] = self.gain * v
        return [None] * len(items)


def _read_echo(p, table, key):
    return {"gain": p.number(table, "gain", f"{key}.gain", 1.0, positive=True)}


@pytest.fixture
def echo():
    register_protocol(
        Protocol(
            "echo",
            keys=("gain",),
            read=_read_echo,
            check_address=lambda a: None if a[0] in "rp" else f"not a register: {a!r}",
            adapter=f"{__name__}:EchoAdapter",
        )
    )
    yield
    del PROTOCOLS["echo"]


TEXT = """
[connections.dev]
protocol = "echo"
gain = 2.0
[[loops]]
name = "a"
ts = 0.1
block = { type = "PID", kp = 0.2, ti = 0.5, u_min = 0.0, u_max = 10.0 }
pv = "dev:pv"
mv = "dev:r1"
sp = 3.0
safe_value = 0.0
[historian]
backend = "none"
"""


def test_a_registered_protocol_is_read_checked_and_run_without_another_edit(echo):
    cfg = parse_config(TEXT)
    assert cfg.connections["dev"].options == {"gain": 2.0}
    clock = FakeClock()
    rt = Runtime(cfg, clock=clock, retain=None)

    async def main():
        await rt.start()
        await clock.run_until(20.0)
        st = rt.state("a")
        await rt.stop()
        return st

    st = bounded(main())
    assert st["mv"] == pytest.approx(1.5, abs=1e-3) and st["pv"] == pytest.approx(3.0, abs=2e-3)
    assert EchoAdapter.instances[-1].values["r1"] == 0.0  # the stop value, written at the stop


@pytest.mark.parametrize(
    ("edit", "problem"),
    [
        (("gain = 2.0", "gain = -1.0"), "connections.dev.gain: must be a finite number > 0"),
        (("gain = 2.0", "gian = 2.0"), "unknown key 'gian'"),
        (('mv = "dev:r1"', 'mv = "dev:x1"'), "loops[0].mv: not a register: 'x1'"),
    ],
)
def test_the_registered_protocol_checks_its_keys_and_addresses(echo, edit, problem):
    with pytest.raises(RuntimeConfigError) as err:
        parse_config(TEXT.replace(*edit))
    assert problem in str(err.value)


def test_an_unregistered_protocol_is_refused_with_the_registered_ones():
    with pytest.raises(RuntimeConfigError) as err:
        parse_config(TEXT)
    assert "connections.dev.protocol: must be one of opcua, modbus, memory; got 'echo'" in str(
        err.value
    )


def test_a_protocol_without_a_module_class_adapter_is_refused():
    with pytest.raises(ValueError, match="module:Class"):
        register_protocol(Protocol("x", adapter="nowhere"))
    assert "x" not in PROTOCOLS


def test_the_built_in_protocols_name_their_libraries():
    assert {n: p.package for n, p in PROTOCOLS.items()} == {
        "opcua": "asyncua",
        "modbus": "pymodbus",
        "memory": None,
    }
