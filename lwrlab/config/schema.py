"""What every schema shares: the decorator that makes a class a schema, and the keys of a built node."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar, dataclass_transform

Settings = TypeVar("Settings")


@dataclass_transform()
def schema(cls: type[Settings]) -> type[Settings]:
    """A dataclass whose fields OmegaConf reads as a schema, without the methods a dataclass generates.

    OmegaConf reads only the fields (names, types, no defaults) and never calls ``__init__``;
    generating ``__init__``, ``__repr__`` and ``__eq__`` for every schema would cost ``lwrlab``'s
    start-up about as much again as registering them.
    """
    return dataclass(init=False, repr=False, eq=False)(cls)


@schema
class Instantiable:
    """A node ``hydra.utils.instantiate`` builds: the callable and whether its inputs come later."""

    _target_: str
    """Dotted path of the class or function built."""
    _partial_: bool
    """True: a ``functools.partial``, completed at run time (the robot, the job's config)."""
