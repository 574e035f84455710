"""Reading TOML files with errors that name the file, the line and the key path.

The scenario files of the simulator and the runtime's configuration files are
read with the same helpers: :func:`read_toml` (a syntax error names the line),
:class:`TableReader` (typed getters; a wrong value names its key path, e.g.
``controllers[2].kp`` or ``loops[0].pv``) and :class:`KeyPathError`, the base
of both files' errors (:class:`~ctrlblocks.sim.ScenarioError`,
:class:`~ctrlblocks.runtime.RuntimeConfigError`).
"""

from __future__ import annotations

import difflib
import math
import re
import sys
from collections.abc import Iterable, Mapping
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "NAME_RE",
    "KeyPathError",
    "TableReader",
    "read_toml",
    "type_name",
    "unknown_key_problem",
]

NAME_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")
"""Names (of scenarios, runtime loops and connections): letters, digits, ``_ . -``."""


class KeyPathError(ValueError):
    """A TOML file (scenario, runtime configuration) is malformed.

    ``file``, ``key`` (key path, e.g. ``loops[0].pv``), ``problem`` and
    ``line`` (or None) are attributes; the message reads
    ``FILE[, line N]: KEY: PROBLEM``.
    """

    def __init__(self, file: str, key: str, problem: str, line: int | None = None) -> None:
        self.file, self.key, self.problem, self.line = file, key, problem, line
        where = file + (f", line {line}" if line else "")
        msg = f"{where}: {key}: {problem}" if key else f"{where}: {problem}"
        super().__init__(msg)


def read_toml(text: str, file: str, error: type[KeyPathError] = KeyPathError) -> dict[str, Any]:
    """Parse TOML ``text``; a syntax error raises ``error`` with the line of ``file``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        line = int(m.group(1)) if m else None
        problem = re.sub(r"\s*\(at line \d+, column \d+\)", "", msg)
        raise error(file, "", f"TOML syntax error: {problem}", line) from None


class TableReader:
    """Typed getters over TOML tables that report errors as ``error(file, key path, problem)``.

    The scenario parser (``error = ScenarioError``) and the runtime's
    configuration parser (``error = RuntimeConfigError``) read their files
    with it; a subclass sets :attr:`error`.
    """

    error: type[KeyPathError] = KeyPathError

    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, key: str, problem: str) -> KeyPathError:
        """The error to raise for ``key`` (the caller raises it)."""
        return self.error(self.file, key, problem)

    def table(self, doc: Mapping[str, Any], name: str, key: str, required: bool) -> dict:
        """``doc[name]`` as a table (``{}`` when absent and not required)."""
        if name not in doc:
            if required:
                raise self.fail(key, "missing table")
            return {}
        return self.as_table(doc[name], key)

    def as_table(self, v: Any, key: str) -> dict:
        """``v`` itself, checked to be a table (an entry of an array of tables, ...)."""
        if not isinstance(v, dict):
            raise self.fail(key, f"must be a table, got {type_name(v)}")
        return v

    def number(
        self,
        d: Mapping[str, Any],
        name: str,
        key: str,
        *,
        default: Any = ...,
        positive: bool = False,
        allow_nan: bool = True,
    ) -> Any:
        """``d[name]`` as a float (``default`` when absent; no default: required)."""
        if name not in d:
            if default is ...:
                raise self.fail(key, "missing (a number is required)")
            return default
        v = d[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(key, f"must be a number, got {type_name(v)} {v!r}")
        x = float(v)
        if not allow_nan and math.isnan(x):
            raise self.fail(key, "must not be NaN")
        if not math.isfinite(x) and positive:
            raise self.fail(key, f"must be finite, got {v!r}")
        if positive and x <= 0:
            raise self.fail(key, f"must be > 0, got {v!r}")
        return x

    def string(self, d: Mapping[str, Any], name: str, key: str, *, default: Any = ...) -> Any:
        """``d[name]`` as a string (``default`` when absent; no default: required)."""
        if name not in d:
            if default is ...:
                raise self.fail(key, "missing (a string is required)")
            return default
        v = d[name]
        if not isinstance(v, str):
            raise self.fail(key, f"must be a string, got {type_name(v)} {v!r}")
        return v

    def check_keys(self, d: Mapping[str, Any], allowed: set[str], key: str) -> None:
        """Refuse the first key of ``d`` that is not ``allowed`` (naming the allowed ones)."""
        unknown = sorted(set(d) - allowed)
        if unknown:
            where = f"{key}.{unknown[0]}" if key else unknown[0]
            raise self.fail(where, unknown_key_problem(unknown[0], allowed))


def type_name(v: Any) -> str:
    """How an error message names the TOML type of ``v`` (``"a table"``, ``"a string"``, ...)."""
    return {
        dict: "a table",
        list: "an array",
        str: "a string",
        bool: "a boolean",
        int: "an integer",
        float: "a number",
    }.get(type(v), type(v).__name__)


def unknown_key_problem(name: str, allowed: Iterable[str]) -> str:
    """``"unknown key 'omegac' (did you mean 'omega_c'?); valid keys: ..."``.

    The hint is the closest allowed key (:func:`difflib.get_close_matches`),
    given only when one is close enough.
    """
    keys = sorted(set(allowed))
    close = difflib.get_close_matches(name, keys, n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return f"unknown key {name!r}{hint}; valid keys: {', '.join(keys)}"
