"""Block and controller specs, the registry of block and plant types, and the block factory.

A :class:`BlockSpec` is one block (or plant) table of a file: its ``type`` and
its keyword arguments, with the key path for error messages.  A
:class:`ControllerSpec` is one controller entry: its blocks by role (see
:mod:`.structures`).  :func:`build` makes the object a spec describes from
the types registered in :data:`BLOCK_TYPES` (the blocks' registry,
:mod:`ctrlblocks.blocks.registry`) and :data:`PLANT_TYPES` (:func:`register`
adds one), so the simulator's scenarios and the runtime's
loops accept exactly the same tables.

:class:`SpecReader` reads a block table (``{ type = "PID", kp = 2.0, ... }``)
and builds it once, so a parameter the block refuses is reported with its key
path where the file is read, not in the middle of a run.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from .. import plants
from ..blocks.base import ParameterError
from ..blocks.registry import BLOCK_TYPES, register_block
from ..plants.base import Plant
from .toml import KeyPathError, TableReader, unknown_key_problem

__all__ = [
    "BLOCK_TYPES",
    "PLANT_TYPES",
    "BlockSpec",
    "ControllerSpec",
    "SpecReader",
    "TuneHook",
    "available_types",
    "build",
    "parameter_names",
    "register",
]


@dataclasses.dataclass(frozen=True)
class BlockSpec:
    """A block or plant to build: a class name and its keyword arguments."""

    type: str
    params: Mapping[str, Any]
    key: str  # key path in the file, for error messages
    extra: Mapping[str, Any] = dataclasses.field(default_factory=dict)  # structure-only keys


@dataclasses.dataclass(frozen=True)
class ControllerSpec:
    """One controller entry (a scenario's ``[[controllers]]`` entry, a runtime loop's blocks)."""

    name: str
    blocks: Mapping[str, Any]  # role -> BlockSpec (override: "blocks" -> list[BlockSpec])
    options: Mapping[str, Any]  # selector, aw_handshake, color, ...


def _exported(package: Any, base: type) -> dict[str, Callable[..., Any]]:
    """The concrete subclasses of ``base`` that ``package`` exports, by class name."""
    out: dict[str, Callable[..., Any]] = {}
    for name in package.__all__:
        cls = getattr(package, name)
        concrete = inspect.isclass(cls) and not inspect.isabstract(cls)
        if concrete and issubclass(cls, base) and cls is not base:
            out[name] = cls
    return out


PLANT_TYPES: dict[str, Callable[..., Any]] = _exported(plants, Plant)
"""Plant types a ``type = "..."`` of a ``[plant]`` (or Smith model) table names: the
plants :mod:`ctrlblocks.plants` exports, plus :func:`register`'s."""

_REGISTRIES: dict[str, dict[str, Any]] = {"block": BLOCK_TYPES, "plant": PLANT_TYPES}
"""``BLOCK_TYPES`` is the blocks' own registry (:mod:`ctrlblocks.blocks.registry`): block
types a ``type = "..."`` of a controller table names."""


def register(kind: str, cls: Callable[..., Any], name: str | None = None) -> None:
    """Make ``cls`` usable as ``type = NAME`` (default its ``__name__``) for ``kind``.

    ``kind`` is ``"block"`` or ``"plant"``; a block of your own package is then
    accepted in scenarios and runtime configurations like the shipped ones
    (a block: :func:`ctrlblocks.blocks.registry.register_block`).
    """
    if kind == "block":
        register_block(cls, name)  # type: ignore[arg-type]
    else:
        _REGISTRIES[kind][name or cls.__name__] = cls


def available_types(kind: str) -> list[str]:
    """Names usable as ``type`` for ``kind`` ``"plant"`` or ``"block"``."""
    return sorted(_REGISTRIES[kind])


def parameter_names(cls: Callable[..., Any]) -> set[str] | None:
    """The keyword parameters a block or plant class takes (None: it takes any)."""
    names = _parameter_names(cls)
    return None if names is None else set(names)


@functools.lru_cache(maxsize=256)
def _parameter_names(cls: Callable[..., Any]) -> frozenset[str] | None:
    """:func:`parameter_names`, read once per class (``inspect.signature`` is slow)."""
    config_cls = getattr(cls, "Config", None)
    if dataclasses.is_dataclass(config_cls):
        return frozenset(f.name for f in dataclasses.fields(config_cls))
    try:
        params = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):  # pragma: no cover - builtins without signature
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params):
        return None
    return frozenset(
        p.name
        for p in params
        if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    )


def build(
    spec: BlockSpec,
    ts: float,
    *,
    kind: str,
    file: str = "<scenario>",
    other_keys: Iterable[str] = (),
    error: type[KeyPathError] = KeyPathError,
) -> Any:
    """Make the block or plant ``spec`` describes, with ``ts`` unless it sets its own.

    Raises ``error`` (a :class:`~.toml.KeyPathError`) naming the key path when
    the type is unknown, a key is not a parameter of the class ("unknown key
    'omegac' (did you mean 'omega_c'?); valid keys: ...", the valid keys being
    the parameters, ``type`` and ``other_keys``) or the class refuses a value.
    """
    cls = _REGISTRIES[kind].get(spec.type)
    if cls is None:
        raise error(
            file,
            f"{spec.key}.type",
            f"unknown {kind} type {spec.type!r}; available: {', '.join(available_types(kind))}",
        )
    params = dict(spec.params)
    names = parameter_names(cls)
    if names is not None:
        unknown = sorted(set(params) - names)
        if unknown:
            raise error(
                file,
                f"{spec.key}.{unknown[0]}",
                unknown_key_problem(unknown[0], {"type", *names, *other_keys}),
            )
    if "ts" not in params and names is not None and "ts" in names:
        params["ts"] = ts
    try:
        return cls(**params)
    except ParameterError as exc:
        problem = f"{exc.message} (error 16#{exc.code:04X} {exc.code.name})"
        raise error(file, f"{spec.key}.{exc.field}", problem) from None
    except TypeError as exc:
        msg = str(exc)
        if not msg.startswith(f"{spec.type}:"):  # the block may name itself already
            msg = f"{spec.type}: {msg}"
        raise error(file, spec.key, msg) from None
    except (ValueError, KeyError) as exc:
        raise error(file, spec.key, f"{spec.type} refused the parameters: {exc}") from None


TuneHook = Callable[[Any, str, str, float], "tuple[dict[str, Any], dict[str, Any]]"]
"""``tune(table, key, block_type, ts) -> (parameters, info)``: a ``tune`` table of a block.

The simulator's parser passes one (a bump test on the scenario's plant); the
runtime passes none, so ``tune`` is refused there.
"""


class SpecReader(TableReader):
    """A :class:`~.toml.TableReader` that also reads block tables into checked specs."""

    def build(
        self, spec: BlockSpec, ts: float, *, kind: str, other_keys: Iterable[str] = ()
    ) -> Any:
        """:func:`build` with this reader's file and error class."""
        return build(spec, ts, kind=kind, file=self.file, other_keys=other_keys, error=self.error)

    def block_spec(
        self,
        d: dict[str, Any],
        key: str,
        ts: float,
        *,
        kind: str = "plant",
        extra_keys: tuple[str, ...] = (),
        tune: TuneHook | None = None,
        table_keys: tuple[str, ...] = (),
    ) -> BlockSpec:
        """The block or plant of table ``d`` (``type`` + its parameters), built once to check it.

        ``extra_keys`` are keys of the table that belong to the structure (an
        override block's ``measure``), read into ``BlockSpec.extra``;
        ``table_keys`` are other keys of the same table that the caller has
        taken out (they are listed among the valid keys of an unknown-key
        error); ``tune`` reads a ``tune`` table (None: ``tune`` is refused).
        """
        self.as_table(d, key)
        tname = self.string(d, "type", f"{key}.type")
        params = {k: v for k, v in d.items() if k not in ("type", "tune") and k not in extra_keys}
        extra = {k: d[k] for k in extra_keys if k in d}
        if "tune" in d:
            if tune is None:
                raise self.fail(
                    f"{key}.tune",
                    "tuning from a bump test needs the single, feedforward or smith structure",
                )
            tuned, info = tune(d["tune"], f"{key}.tune", tname, ts)
            params = {**params, **tuned}
            extra = {**extra, "tuned": info}
        spec = BlockSpec(tname, params, key, extra)
        # build once so that a refused parameter is reported with its key path
        others = (*extra_keys, *table_keys, *(("tune",) if kind == "block" else ()))
        self.build(spec, ts, kind=kind, other_keys=others)
        return spec

    def role(
        self,
        entry: dict[str, Any],
        role: str,
        key: str,
        ts: float,
        tune: TuneHook | None = None,
        *,
        kind: str = "block",
    ) -> BlockSpec:
        """The table ``ROLE`` of a controller entry (``main``, ``model``, ...)."""
        return self.block_spec(
            self.table(entry, role, f"{key}.{role}", True),
            f"{key}.{role}",
            ts,
            kind=kind,
            tune=tune,
        )
