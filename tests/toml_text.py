"""TOML text for tests that write scenario and configuration files: one value, one table."""

from __future__ import annotations

from typing import Any


def toml_value(value: Any) -> str:
    """``value`` as TOML: booleans, strings, lists and tuples (as arrays), numbers."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


def toml_table(header: str, /, **keys: Any) -> str:
    """A TOML table ``[header]`` with ``keys`` (``header = "[cases]"`` gives ``[[cases]]``)."""
    return f"[{header}]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in keys.items())
