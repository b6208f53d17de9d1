"""Robots described by a URDF file (config ``robot=urdf``).

The loader lives in the core, :mod:`lwrlab.model.urdf_robot` (as the modified-DH loaders live in
:mod:`lwrlab.model.description`), where every robot plugin reaches it without depending on another
plugin; its docstring says what is read from the URDF and what is given beside it.
"""

from __future__ import annotations

from lwrlab.model.urdf_robot import URDFNotFoundError, load_urdf_robot

__all__ = ["URDFNotFoundError", "load_urdf_robot"]
