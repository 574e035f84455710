"""Process models to test the blocks on (see :mod:`.base` for the contract)."""

from .base import Plant

__all__ = ["Plant"]
