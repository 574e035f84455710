"""An answer that is not the answer to the request is refused, never decoded (Modbus, OPC UA).

Found by the slow-device benchmark (issue 36): with answers delayed beyond
the connection's timeout, the plant server's Modbus device answered a read
with a write's response under the read's transaction identifier; the
adapter indexed the missing registers and the connection was dropped with
"list index out of range".  A read answered with the right function but
another request's register count would have been decoded as this read's
values.  Now every answer is checked against its request (function, register
count; a write's echoed address and count), and a mismatch is an ``IOFault``
that says so (the connection resets, which puts it back in step).  The same
for an OPC UA server whose Read or Write gives another number of results
than nodes asked (Part 4: one result per node).
"""

from __future__ import annotations

import asyncio

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.pdu import ExceptionResponse
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersResponse,
    ReadInputRegistersResponse,
    WriteMultipleRegistersResponse,
)

from ctrlblocks.runtime.config import ConnectionConfig
from ctrlblocks.runtime.io import IOFault
from ctrlblocks.runtime.modbus import ModbusAdapter, float32_to_registers


class Device:
    """A pymodbus client stand-in: every request gets ``answer(request)``."""

    connected = True

    def __init__(self, answer):
        self.answer = answer

    async def read_holding_registers(self, start, count, device_id):
        return self.answer(("read", 3, start, count))

    async def read_input_registers(self, start, count, device_id):
        return self.answer(("read", 4, start, count))

    async def write_registers(self, start, words, device_id):
        return self.answer(("write", 16, start, len(words)))


def adapter(answer) -> ModbusAdapter:
    a = ModbusAdapter(ConnectionConfig(name="dev", protocol="modbus"))
    a._client = Device(answer)
    return a


def right(request):
    kind, fc, start, count = request
    if kind == "write":
        return WriteMultipleRegistersResponse(address=start, count=count)
    words = [w for k in range(start, start + count, 2) for w in float32_to_registers(k + 0.5)]
    cls = ReadHoldingRegistersResponse if fc == 3 else ReadInputRegistersResponse
    return cls(registers=words[:count])


def test_the_benchmarks_case_a_read_answered_by_a_write_is_refused_with_what_came():
    a = adapter(lambda req: WriteMultipleRegistersResponse(address=2, count=2))
    with pytest.raises(IOFault, match=r"hr:0\.\.1: the device answered function 16 to "
                                      r"function 3 \(out of step\)"):  # fmt: skip
        asyncio.run(a.read(["hr:0"]))


def test_the_right_answers_are_decoded():
    a = adapter(right)
    got = asyncio.run(a.read(["hr:0", "hr:2", "ir:10"]))
    assert [r.value for r in got] == [0.5, 2.5, 10.5] and all(r.ok for r in got)
    assert asyncio.run(a.write([("hr:4", 1.0), ("hr:6", 2.0)])) == [None, None]


@settings(max_examples=200, deadline=None)
@given(
    fc=st.sampled_from([3, 4, 16, 0x83, 0x84, 0x90, 6]),
    count=st.integers(0, 8),
    address=st.integers(0, 8),
    write=st.booleans(),
)
def test_any_other_answer_is_an_io_fault_never_an_index_error_or_values(
    fc, count, address, write
):
    """Adversarial: answers of any function, register count and address; the adapter
    either decodes the right answer or raises IOFault -- nothing else gets out."""

    def answer(request):
        if fc in (3, 4):
            cls = ReadHoldingRegistersResponse if fc == 3 else ReadInputRegistersResponse
            return cls(registers=[0x3F80, 0] * (count // 2) + [0] * (count % 2))
        if fc == 16:
            return WriteMultipleRegistersResponse(address=address, count=count)
        if fc == 6:
            from pymodbus.pdu.register_message import WriteSingleRegisterResponse

            return WriteSingleRegisterResponse(address=address, registers=[0])
        return ExceptionResponse(fc & 0x7F, 2)

    a = adapter(answer)
    call = a.write([("hr:2", 1.0)]) if write else a.read(["hr:2"])
    matches = (fc == (16 if write else 3) and count == 2 and (address == 2 or not write)) or (
        fc & 0x7F == (16 if write else 3) and fc & 0x80
    )
    if matches:
        out = asyncio.run(call)
        assert len(out) == 1
    else:
        with pytest.raises(IOFault, match=r"out of step"):
            asyncio.run(call)


class UaServer:
    """An asyncua ``uaclient`` stand-in answering ``drop`` results fewer than asked."""

    def __init__(self, drop: int) -> None:
        self.drop = drop

    async def read_attributes(self, nodes, attribute):
        from asyncua import ua

        n = max(len(nodes) - self.drop, 0)
        if attribute == ua.AttributeIds.DataType:
            return [ua.DataValue(ua.Variant(ua.NodeId(11, 0)))] * n  # Double
        return [ua.DataValue(ua.Variant(1.5, ua.VariantType.Double))] * n

    async def write_attributes(self, nodes, values, attribute):
        from asyncua import ua

        return [ua.StatusCode(0)] * max(len(nodes) - self.drop, 0)


@pytest.mark.parametrize("drop", [0, 1])
@pytest.mark.parametrize("write", [False, True])
def test_an_opcua_answer_with_another_number_of_results_is_an_io_fault(drop, write):
    from ctrlblocks.runtime.opcua import OpcUaAdapter

    a = OpcUaAdapter(ConnectionConfig(name="ua", protocol="opcua", url="opc.tcp://x:4840"))
    a._client = type("Client", (), {"uaclient": UaServer(drop)})()
    nodes = ["ns=2;s=a", "ns=2;s=b"]
    if write:  # the data types known: the Write's own results are what is checked
        from asyncua import ua

        a._types = dict.fromkeys(nodes, ua.VariantType.Double)
    call = a.write([(n, 1.0) for n in nodes]) if write else a.read(nodes)
    if drop == 0:
        out = asyncio.run(call)
        assert out == ([None, None] if write else out) and len(out) == 2
    else:
        what = "write" if write else "read"
        with pytest.raises(IOFault, match=rf"OPC UA {what}: the server answered 1 results to 2"):
            asyncio.run(call)
