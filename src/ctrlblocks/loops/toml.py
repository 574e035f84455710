"""Reading TOML files with errors that name the file, the line and the key path.

The scenario files of the simulator and the runtime's configuration files are
read with the same helpers: :func:`read_text` (an unreadable or non-UTF-8
file), :func:`read_toml` (a syntax error names the line), :class:`TableReader`
(typed getters; a wrong value names its key path, e.g. ``controllers[2].kp``
or ``loops[0].pv``) and :class:`KeyPathError`, the base of both files' errors
(:class:`~ctrlblocks.sim.ScenarioError`,
:class:`~ctrlblocks.runtime.RuntimeConfigError`).

A parser works on the parsed document, which knows no lines; a parser that
has the text wraps its work in :func:`located`, which gives an error that
passes the line of its key path in the text (:meth:`KeyPathError.locate`).
The text is scanned (:func:`key_lines`) only then: a valid document -- every
parameter set of a sweep -- pays nothing for it.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import re
import sys
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "NAME_RE",
    "KeyPathError",
    "TableReader",
    "key_line",
    "key_lines",
    "located",
    "read_text",
    "read_toml",
    "type_name",
    "unknown_key_problem",
]

NAME_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")
"""Names (of scenarios, runtime loops and connections): letters, digits, ``_ . -``."""


class KeyPathError(ValueError):
    """A TOML file (scenario, runtime configuration) is malformed.

    ``file``, ``key`` (key path, e.g. ``loops[0].pv``), ``problem`` and
    ``line`` (or None: a document built in Python, or no line known) are
    attributes; the message reads ``FILE[, line N]: KEY: PROBLEM``.
    """

    def __init__(self, file: str, key: str, problem: str, line: int | None = None) -> None:
        self.file, self.key, self.problem, self.line = file, key, problem, line
        super().__init__(self._message())

    def _message(self) -> str:
        where = self.file + (f", line {self.line}" if self.line else "")
        return f"{where}: {self.key}: {self.problem}" if self.key else f"{where}: {self.problem}"

    def __reduce__(self) -> tuple[Any, ...]:
        # rebuilt from the attributes (a process pool ships it back from a worker)
        return type(self), (self.file, self.key, self.problem, self.line)

    def locate(self, text: str) -> KeyPathError:
        """Give this error the line of ``text`` that writes its key path (:func:`key_line`).

        An error that has a line, or no key path, or whose key is not written
        in ``text`` is left as it is.  Returns the error itself.
        """
        if self.line is None and self.key:
            line = key_line(text, self.key)
            if line is not None:
                self.line = line
                self.args = (self._message(),)
        return self


@contextlib.contextmanager
def located(text: str | None) -> Iterator[None]:
    """A :class:`KeyPathError` leaving the block gets the line of its key path in ``text``.

    ``text`` is the TOML text the checked document was read from (None: a
    document built in Python, no line).  The text is scanned only when an
    error passes.
    """
    try:
        yield
    except KeyPathError as exc:
        if text is not None:
            exc.locate(text)
        raise


def read_text(path: Path, error: type[KeyPathError] = KeyPathError) -> str:
    """The text of the TOML file ``path``; unreadable or not UTF-8: ``error`` naming it."""
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise error(str(path), "", f"cannot read the file ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:  # a binary file, or a text saved in another encoding
        line = exc.object[: exc.start].count(b"\n") + 1
        problem = f"not a UTF-8 text file (byte 0x{exc.object[exc.start]:02x})"
        raise error(str(path), "", problem, line) from None


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


_BARE_OR_QUOTED = r"[A-Za-z0-9_\-]+|\"[^\"]*\"|'[^']*'"
_TABLE_LINE = re.compile(r"^\s*(\[\[?)([^\]]*)\]\]?\s*(?:#.*)?$")
_KEY_LINE = re.compile(rf"^\s*((?:{_BARE_OR_QUOTED})(?:\s*\.\s*(?:{_BARE_OR_QUOTED}))*)\s*=")


def _key_parts(dotted: str) -> list[str]:
    return [k.strip("\"'") for k in re.findall(_BARE_OR_QUOTED, dotted)]


def key_lines(text: str) -> dict[str, int]:
    """Key path (``loops[1].block.kp``, ``historian``) -> the line (1-based) that writes it.

    A line scan of the TOML ``text`` (already parsed, so well formed):
    table headers, ``[[array]]`` entries counted, dotted keys; lines inside
    multi-line strings are skipped.  The first line wins.
    """
    lines: dict[str, int] = {}
    arrays: dict[str, int] = {}  # array of tables (resolved path) -> entries so far
    table, in_string = "", False
    for n, raw in enumerate(text.splitlines(), 1):
        if in_string:
            in_string = (raw.count('"""') + raw.count("'''")) % 2 == 0
            continue
        if (raw.count('"""') + raw.count("'''")) % 2 == 1:
            in_string = True
        m = _TABLE_LINE.match(raw)
        if m:
            parts, path = _key_parts(m.group(2)), ""
            for i, part in enumerate(parts):
                path = f"{path}.{part}" if path else part
                if m.group(1) == "[[" and i == len(parts) - 1:
                    arrays[path] = arrays.get(path, 0) + 1
                if path in arrays:
                    path = f"{path}[{arrays[path] - 1}]"
                lines.setdefault(path, n)
            table = path
            continue
        m = _KEY_LINE.match(raw)
        if m:
            path = table
            for part in _key_parts(m.group(1)):
                path = f"{path}.{part}" if path else part
                lines.setdefault(path, n)
    return lines


def key_line(text: str, key: str) -> int | None:
    """The line of TOML ``text`` that writes ``key`` or, failing that, its nearest parent."""
    lines = key_lines(text)
    while key:
        if key in lines:
            return lines[key]
        key = re.sub(r"(\.[^.\[\]]*|\[\d+\])$", "", key) if re.search(r"[.\[]", key) else ""
    return None


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
        allow_nan: bool = False,
        limit: bool = False,
    ) -> Any:
        """``d[name]`` as a float (``default`` when absent; no default: required).

        A NaN written in the file is refused unless ``allow_nan`` (no field of a
        scenario or a runtime configuration means anything by it: a bad
        measurement is ``nan = true`` of a ``sensor`` event).  ``+-inf`` is
        refused unless the field is a ``limit`` (a range's end or a rate: there
        ``inf`` means no limit); a noise level, a time or a value has no
        meaning for it, and accepting it only moves the error to the run.
        """
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
        if math.isinf(x) and (positive or not limit):
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
