"""Modbus TCP client adapter (pymodbus, tested with 3.16): FLOAT32 values in register pairs.

Addresses are ``hr:N`` (holding registers N, N+1; read with function 3,
written with function 16) or ``ir:N`` (input registers, read only, function
4); a bare ``N`` is a holding register.  A value is an IEEE 754 single
(FLOAT32) in two 16-bit registers, each register big-endian as Modbus
prescribes; ``word_order`` says which register holds the high word:

===========  ===================  =====================
word_order   register N           register N+1
===========  ===================  =====================
``"big"``    high word (AB)       low word (CD)   "ABCD"
``"little"`` low word (CD)        high word (AB)  "CDAB"
===========  ===================  =====================

A value is written as the nearest FLOAT32, so a loop running on Modbus sees
its values rounded to about 7 significant digits.

Batching: a cycle's reads are coalesced into contiguous register ranges of
one kind (at most :data:`MAX_READ_REGISTERS` registers per request, the
protocol's limit for functions 3 and 4), its writes into contiguous holding
register ranges (at most :data:`MAX_WRITE_REGISTERS` per function 16).  A
device that refuses a range (an exception response) marks every value in
that range bad.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from typing import Any

from .config import ConnectionConfig, parse_modbus_address
from .io import Adapter, IOFault, Reading, bad, checked, describe

__all__ = ["ModbusAdapter", "coalesce", "float32_to_registers", "registers_to_float32"]

MAX_READ_REGISTERS = 125
"""Registers per read request (Modbus application protocol, functions 3 and 4)."""

MAX_WRITE_REGISTERS = 122
"""Registers per write request (function 16 allows 123; FLOAT32 pairs: 122)."""


def coalesce(registers: Sequence[int], limit: int) -> list[tuple[int, int]]:
    """Contiguous ``(start, count)`` ranges covering the FLOAT32 pairs at ``registers``.

    Pairs that touch or overlap join one range while it stays within
    ``limit`` registers; a gap starts a new range.

    >>> coalesce([0, 2, 4, 10, 12], 125)
    [(0, 6), (10, 4)]
    >>> coalesce([0, 2, 4], 4)
    [(0, 4), (4, 2)]
    """
    out: list[tuple[int, int]] = []
    for r in sorted(set(registers)):
        if out:
            start, count = out[-1]
            end = start + count
            if r <= end and r + 2 - start <= limit:
                out[-1] = (start, max(end, r + 2) - start)
                continue
        out.append((r, 2))
    return out


def float32_to_registers(value: float, word_order: str = "big") -> tuple[int, int]:
    """Two 16-bit registers holding ``value`` as FLOAT32 (see the module table).

    >>> [hex(r) for r in float32_to_registers(1.0)]
    ['0x3f80', '0x0']
    >>> [hex(r) for r in float32_to_registers(1.0, "little")]
    ['0x0', '0x3f80']
    """
    hi, lo = struct.unpack(">HH", struct.pack(">f", value))
    return (hi, lo) if word_order == "big" else (lo, hi)


def registers_to_float32(regs: Sequence[int], word_order: str = "big") -> float:
    """The FLOAT32 in two registers (inverse of :func:`float32_to_registers`)."""
    a, b = int(regs[0]), int(regs[1])
    hi, lo = (a, b) if word_order == "big" else (b, a)
    return struct.unpack(">f", struct.pack(">HH", hi, lo))[0]


def _pymodbus():
    try:
        from pymodbus.client import AsyncModbusTcpClient
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError(
            "the Modbus adapter needs pymodbus: pip install 'ctrlblocks[runtime]'"
        ) from exc
    return AsyncModbusTcpClient


class ModbusAdapter(Adapter):
    """Modbus TCP client (see the module docstring)."""

    def __init__(self, config: ConnectionConfig) -> None:
        self.config = config
        self._client = None
        self._order = config.word_order

    async def connect(self) -> None:
        client_cls = _pymodbus()
        c = self.config
        client = client_cls(c.host, port=c.port, timeout=c.timeout, retries=0, reconnect_delay=0.0)
        ok = await client.connect()
        if not ok:
            client.close()
            raise IOFault(f"Modbus TCP {c.host}:{c.port}: connection refused")
        self._client = client

    async def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def _live(self):
        if self._client is None or not self._client.connected:
            raise IOFault("Modbus connection closed")
        return self._client

    async def read(self, addresses: Sequence[str]) -> list[Reading]:
        client = self._live()
        parsed = [parse_modbus_address(a) for a in addresses]
        values: dict[tuple[str, int], Reading] = {}
        for kind in ("hr", "ir"):
            regs = [r for k, r in parsed if k == kind]
            fn = client.read_holding_registers if kind == "hr" else client.read_input_registers
            for start, count in coalesce(regs, MAX_READ_REGISTERS):
                where = f"{kind}:{start}..{start + count - 1}"
                self.count("read")
                try:
                    rr = await fn(start, count=count, device_id=self.config.unit)
                except Exception as exc:
                    raise IOFault(f"Modbus read {where}: {describe(exc)}") from exc
                if why := _mismatch(rr, 3 if kind == "hr" else 4, count=count):
                    raise IOFault(f"Modbus read {where}: {why}")
                for r in regs:
                    if start <= r < start + count:
                        if rr.isError():
                            values[kind, r] = bad(_exception(rr, f"{kind}:{r}"))
                        else:
                            i = r - start
                            values[kind, r] = checked(
                                registers_to_float32(rr.registers[i : i + 2], self._order)
                            )
        return [values[p] for p in parsed]

    async def write(self, items: Sequence[tuple[str, float]]) -> list[str | None]:
        client = self._live()
        res: list[str | None] = [None] * len(items)
        regs: dict[int, tuple[int, int]] = {}  # register -> its two words
        where: dict[int, list[int]] = {}  # register -> indices of the items writing it
        for i, (a, v) in enumerate(items):
            kind, reg = parse_modbus_address(a)
            if kind != "hr":
                res[i] = f"{a}: input registers are read-only"
                continue
            x = float(v)
            if math.isfinite(x) and abs(x) > 3.4028234663852886e38:
                res[i] = f"{a}: {x!r} does not fit a FLOAT32"
                continue
            regs[reg] = float32_to_registers(x, self._order)
            where.setdefault(reg, []).append(i)
        for start, count in coalesce(list(regs), MAX_WRITE_REGISTERS):
            words = [0] * count
            inside = [r for r in regs if start <= r < start + count]
            for r in sorted(inside):
                words[r - start : r - start + 2] = regs[r]
            self.count("write")
            try:
                rr = await client.write_registers(start, words, device_id=self.config.unit)
            except Exception as exc:
                raise IOFault(f"Modbus write hr:{start}: {describe(exc)}") from exc
            if why := _mismatch(rr, 16, count=count, address=start):
                raise IOFault(f"Modbus write hr:{start}..{start + count - 1}: {why}")
            for r in inside:
                for i in where[r]:
                    res[i] = _exception(rr, items[i][0]) if rr.isError() else None
        return res


def _mismatch(response: Any, function: int, count: int, address: int | None = None) -> str:
    """Why ``response`` is not the answer to the request (function ``function`` on ``count``
    registers from ``address``); "" when it is.

    The transaction identifier matches (the client checks it), but a device
    can still answer out of step -- the plant server's own did, a read
    answered with a write's response, when a request had timed out while the
    device still worked on it -- and a register count or function of
    another request must never be decoded as this one's values.  Function 3
    and 4 answers carry their byte count (so their register count), function
    16 answers echo the address and count written.  A mismatch is a
    connection fault (the connection is reset, which puts it back in step).
    """
    fc = int(getattr(response, "function_code", -1))
    if response.isError():  # an exception response: of this function, or out of step
        if fc & 0x7F == function:
            return ""
        return f"the device answered function {fc & 0x7F} to function {function} (out of step)"
    if fc != function:
        return f"the device answered function {fc} to function {function} (out of step)"
    if function in (3, 4):
        n = len(getattr(response, "registers", ()) or ())
        if n != count:
            return f"the device answered {n} registers to a read of {count} (out of step)"
    elif (getattr(response, "address", None), getattr(response, "count", None)) != (address, count):
        got = f"{getattr(response, 'count', '?')} at {getattr(response, 'address', '?')}"
        return f"the device confirmed {got} for a write of {count} at {address} (out of step)"
    return ""


def _exception(response: Any, address: str) -> str:
    """The reason of a Modbus exception response (the server refused the request)."""
    return f"Modbus exception {getattr(response, 'exception_code', '?')} on {address}"
