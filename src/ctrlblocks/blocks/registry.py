"""The block types by name: the one list of what ``type = "..."`` may name.

:data:`BLOCK_TYPES` maps a name to its class: every concrete block that
:mod:`ctrlblocks.blocks` exports, plus the ones :func:`register_block` adds
(a block of your own package).  Code that needs a block type by its name, or
the controllers among them, or a type's parameters, asks here instead of
naming the classes (a scenario's ``type``, a runtime loop's block, a tuning
rule's family, the faceplate's list of types): a new block type is then one
:func:`register_block` (or one export), not an edit of every such place.

A type is a *controller* when its class has the methods of the
:class:`~ctrlblocks.blocks.protocols.Controller` interface (the two phases,
the one call, ``set_limits``; the attributes of the interface belong to its
instances), or when :func:`register_block` says so.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from typing import Any

import ctrlblocks.blocks as _blocks

from .base import Block

__all__ = [
    "BLOCK_TYPES",
    "Parameter",
    "block_class",
    "controller_types",
    "is_controller_type",
    "parameters",
    "register_block",
]

_CONTROLLER_METHODS = ("__call__", "compute_output", "update_state", "set_limits")


def _concrete_blocks() -> dict[str, type]:
    out: dict[str, type] = {}
    for name in _blocks.__all__:
        cls = getattr(_blocks, name)
        concrete = inspect.isclass(cls) and not inspect.isabstract(cls)
        if concrete and issubclass(cls, Block) and cls is not Block:
            out[name] = cls
    return out


BLOCK_TYPES: dict[str, type] = _concrete_blocks()
"""Block types by name (module docstring)."""

_CONTROLLERS: dict[str, bool] = {}


def register_block(cls: type, name: str | None = None, *, controller: bool | None = None) -> None:
    """Make ``cls`` a block type named ``name`` (default its ``__name__``).

    ``controller`` says whether it is a controller (None: its class has the
    methods of the :class:`~ctrlblocks.blocks.protocols.Controller` interface).
    """
    key = name or cls.__name__
    BLOCK_TYPES[key] = cls
    if controller is None:
        _CONTROLLERS.pop(key, None)
    else:
        _CONTROLLERS[key] = controller


def block_class(name: str) -> type:
    """The class of the block type ``name``; ``KeyError`` naming the types there are."""
    try:
        return BLOCK_TYPES[name]
    except KeyError:
        raise KeyError(
            f"unknown block type {name!r}; available: {', '.join(sorted(BLOCK_TYPES))}"
        ) from None


def is_controller_type(name: str) -> bool:
    """Whether the block type ``name`` is a controller (module docstring)."""
    if name in _CONTROLLERS:
        return _CONTROLLERS[name]
    cls = BLOCK_TYPES.get(name)
    return cls is not None and all(callable(getattr(cls, m, None)) for m in _CONTROLLER_METHODS)


def controller_types() -> list[str]:
    """The names of the controller types, sorted (``["ADRC", "PID"]`` and yours)."""
    return sorted(n for n in BLOCK_TYPES if is_controller_type(n))


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One configuration parameter of a block type."""

    name: str
    default: Any
    """The default value (``None`` also for a parameter without a default)."""
    type: str
    """The annotation as written (``"float"``, ``"float | None"``, ``"str"``, ...)."""

    def as_json(self) -> dict[str, Any]:
        """``{"name", "default", "type"}``, the default JSON-safe (``inf`` as a string)."""
        d = self.default
        if isinstance(d, float) and not math.isfinite(d):
            d = str(d)  # JSON has no inf, nan
        elif isinstance(d, tuple):
            d = list(d)
        elif not isinstance(d, (bool, int, float, str, type(None))):
            d = str(d)  # an enum member and the like: its name
        return {"name": self.name, "default": d, "type": self.type}


def parameters(name: str) -> list[Parameter]:
    """The configuration parameters of the block type ``name``, in their order.

    Read from the type's ``Config`` dataclass (every shipped block has one;
    ``precision`` included); a type without one has none listed.
    """
    cfg = getattr(block_class(name), "Config", None)
    if not dataclasses.is_dataclass(cfg):
        return []
    out = []
    for f in dataclasses.fields(cfg):
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = None
        out.append(Parameter(f.name, default, str(f.type)))
    return out
