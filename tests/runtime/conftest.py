"""Helpers of the runtime tests.

Tests marked ``loopback`` run real protocol servers and clients on 127.0.0.1
in real time (a few hundred cycles of 20 ms); they run in the default suite.
"""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import pytest

DATA = Path(__file__).parent / "data"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "loopback: real-time end-to-end test with servers on 127.0.0.1 (a few s)"
    )


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def block_table(block_type: str, params: dict[str, Any]) -> str:
    items = ", ".join(f"{k} = {toml_value(v)}" for k, v in params.items())
    return f'{{ type = "{block_type}"' + (f", {items}" if items else "") + " }"


def loop_toml(
    *,
    name: str = "loop",
    ts: float = 0.1,
    block: str = '{ type = "PID", kp = 1.0, ti = 1.0, u_min = -10.0, u_max = 10.0 }',
    conn: str = "io",
    sp: str = "1.0",
    extra: str = "",
    safe_value: float = 0.0,
    pv: str = "pv",
    mv: str = "mv",
) -> str:
    return f"""
[[loops]]
name = "{name}"
ts = {ts}
block = {block}
pv = "{conn}:{pv}"
mv = "{conn}:{mv}"
sp = {sp}
safe_value = {safe_value}
{extra}
"""


async def wait_for(pred, timeout: float = 10.0, step: float = 0.01) -> None:
    """Wait (real time) until ``pred()`` is true; fail after ``timeout`` s."""
    loop = asyncio.get_running_loop()
    t_end = loop.time() + timeout
    while not pred():
        if loop.time() > t_end:
            raise AssertionError("condition not reached in time")
        await asyncio.sleep(step)
