"""Robots described by a modified Denavit–Hartenberg table (config group ``robot``).

The robot configs ``conf/robot/kuka_lwr4.yaml`` and ``panda.yaml`` target :func:`build_robot` with
the description's keys; ``conf/robot/mdh_file.yaml`` targets :func:`load_robot_yaml` with the path
of a YAML file holding them. The keys and their units, and the loaders themselves, are in the core,
:mod:`lwrlab.model.description`, where every robot loader (the URDF plugin too) and the rest of
the core reach them without depending on a plugin.
"""

from __future__ import annotations

from lwrlab.model.description import build_robot, load_robot_yaml

__all__ = ["build_robot", "load_robot_yaml"]
