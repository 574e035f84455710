"""Lazy re-exports of a package (PEP 562): a name is imported on first use.

A package ``__init__`` that re-exports names of its modules imports all of
them, and their libraries, as soon as anything of the package is imported --
``ctrlblocks history --help`` would import the runtime's OPC UA layer, and
``ctrlblocks tune --help`` scipy.  With :func:`lazy_exports` the package
imports a module only when one of its names is first read (and keeps the name
then); ``from package import Name``, ``package.Name`` and ``import *`` work as
before.  Type checkers read the same names from an ``if TYPE_CHECKING:``
block of imports next to the table.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import Any


def lazy_exports(
    package: str, where: dict[str, tuple[str, ...]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    ``where`` maps a relative module name (``".historian"``) to the names it
    exports.  An unknown name raises ``AttributeError`` as a module does.
    """
    home = {name: module for module, names in where.items() for name in names}

    def __getattr__(name: str) -> Any:
        if name not in home:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home[name], package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *home})

    return __getattr__, __dir__
