"""What the simulator and the runtime share: TOML reading, specs, loop structures.

* :mod:`.toml` -- :func:`read_toml`, :class:`TableReader` and
  :class:`KeyPathError`: errors name the file, the line and the key path;
* :mod:`.spec` -- :class:`BlockSpec` and :class:`ControllerSpec`, the registry
  of block and plant types (:data:`BLOCK_TYPES`, :data:`PLANT_TYPES`,
  :func:`register`) and the block factory :func:`build`;
* :mod:`.structures` -- one :class:`Structure` object per loop structure
  (:data:`STRUCTURES`) and :class:`ControllerSide`, a controller entry's
  blocks run in Åström's computational order.

This layer sits above the blocks, plants and tuning and below the simulator
and the runtime (docs/architecture.md).
"""

from .spec import (
    BLOCK_TYPES,
    PLANT_TYPES,
    BlockSpec,
    ControllerSpec,
    SpecReader,
    available_types,
    build,
    register,
)
from .structures import STRUCTURES, ControllerSide, Structure, parse_controller, set_manual
from .toml import NAME_RE, KeyPathError, TableReader, read_toml, type_name

__all__ = [
    "BLOCK_TYPES",
    "NAME_RE",
    "PLANT_TYPES",
    "STRUCTURES",
    "BlockSpec",
    "ControllerSide",
    "ControllerSpec",
    "KeyPathError",
    "SpecReader",
    "Structure",
    "TableReader",
    "available_types",
    "build",
    "parse_controller",
    "read_toml",
    "register",
    "set_manual",
    "type_name",
]
