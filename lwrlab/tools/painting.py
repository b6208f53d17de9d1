"""Parametric painting tools: a paint roller and a flat brush, each built from solids.

Both hang from a fixing plate on the flange and point along the flange z axis; the wall is met at
``z = length``. Sizes in m, masses in kg; defaults are those of common hardware-store tools.

Roller (a handle rod, a cage frame along the roller axis and a foam cover on a core)::

    z = 0        plate (disc on the flange)
    …            handle rod along z, up to the roller axis
    z = length − D/2   frame rod along y (from the handle to the far end of the cover when offset)
                       cover: tube along y, length = width, outer diameter D, centred at y = lateral_offset
    z = length   contact line (along y)

Brush (a handle rod, a ferrule and a block of bristles)::

    z = 0        plate
    …            handle rod along z
                 ferrule: box around the bristle roots
    z = length   bristle tips (a line along y of the brush's width)
"""

from __future__ import annotations

import numpy as np

from lwrlab.tools.model import Tool
from lwrlab.tools.shapes import Box, Cylinder


def _plate(mass: float, diameter: float, thickness: float) -> Cylinder:
    return Cylinder(
        mass=mass, center=np.array([0.0, 0.0, thickness / 2]), radius=diameter / 2, length=thickness, axis="z"
    )


def paint_roller(
    name: str,
    length: float,
    width: float,
    cover_mass: float,
    frame_mass: float,
    handle_mass: float,
    plate_mass: float,
    roller_diameter: float = 0.05,
    core_diameter: float = 0.04,
    handle_diameter: float = 0.01,
    plate_diameter: float = 0.063,
    plate_thickness: float = 0.008,
    lateral_offset: float = 0.0,
    description: str = "",
) -> Tool:
    """A paint roller: plate, handle (rod along z), frame (rod along y) and cover (tube along y).

    Parameters
    ----------
    name : library name.
    length : flange face to the contact line (m); the roller axis is at ``length − roller_diameter/2``.
    width : cover length along the roller axis, the painted stripe's width (m).
    cover_mass, frame_mass, handle_mass, plate_mass : masses of the parts (kg).
    roller_diameter, core_diameter : outer and inner diameters of the cover (m).
    handle_diameter : diameter of the handle and frame rods (m).
    plate_diameter, plate_thickness : fixing plate (m).
    lateral_offset : y of the cover's middle (m): 0 for a symmetric yoke, ``width/2`` for a cage
        frame holding the roller from one end.
    """
    if roller_diameter >= length:
        raise ValueError(
            f"roller {name!r}: roller diameter {roller_diameter} m must be below its length {length} m"
        )
    axle_z = length - roller_diameter / 2
    handle_length = axle_z - plate_thickness
    frame_start, frame_end = min(0.0, lateral_offset - width / 2), max(0.0, lateral_offset + width / 2)
    rod = handle_diameter / 2
    parts = {
        "plate": _plate(plate_mass, plate_diameter, plate_thickness),
        "handle": Cylinder(
            mass=handle_mass,
            center=np.array([0.0, 0.0, plate_thickness + handle_length / 2]),
            radius=rod,
            length=handle_length,
            axis="z",
        ),
        "frame": Cylinder(
            mass=frame_mass,
            center=np.array([0.0, (frame_start + frame_end) / 2, axle_z]),
            radius=rod,
            length=frame_end - frame_start,
            axis="y",
        ),
        "cover": Cylinder(
            mass=cover_mass,
            center=np.array([0.0, lateral_offset, axle_z]),
            radius=roller_diameter / 2,
            length=width,
            axis="y",
            inner_radius=core_diameter / 2,
        ),
    }
    return Tool(
        name=name,
        kind="roller",
        length=float(length),
        width=float(width),
        parts=parts,
        contact_point=np.array([0.0, lateral_offset, length]),
        contact_axis=np.array([0.0, 1.0, 0.0]),
        description=description,
    )


def paint_brush(
    name: str,
    length: float,
    width: float,
    bristle_mass: float,
    ferrule_mass: float,
    handle_mass: float,
    plate_mass: float,
    bristle_length: float = 0.05,
    bristle_thickness: float = 0.015,
    ferrule_length: float = 0.03,
    handle_diameter: float = 0.02,
    plate_diameter: float = 0.063,
    plate_thickness: float = 0.008,
    description: str = "",
) -> Tool:
    """A flat paint brush: plate, handle (rod along z), ferrule (box) and bristles (box), all along z.

    Parameters
    ----------
    name : library name.
    length : flange face to the bristle tips (m).
    width : bristle width along y, the painted stripe's width (m).
    bristle_mass, ferrule_mass, handle_mass, plate_mass : masses of the parts (kg).
    bristle_length, bristle_thickness : bristle block's length along z and thickness along x (m).
    ferrule_length : metal band around the bristle roots, along z (m); it is 4 mm larger than the
        bristle block in x and y.
    handle_diameter : (m).
    plate_diameter, plate_thickness : fixing plate (m).
    """
    bristles_start = length - bristle_length
    ferrule_start = bristles_start - ferrule_length / 2  # the ferrule half covers the bristle roots
    handle_length = ferrule_start - plate_thickness
    if handle_length <= 0:
        raise ValueError(f"brush {name!r}: length {length} m leaves no room for the handle")
    parts = {
        "plate": _plate(plate_mass, plate_diameter, plate_thickness),
        "handle": Cylinder(
            mass=handle_mass,
            center=np.array([0.0, 0.0, plate_thickness + handle_length / 2]),
            radius=handle_diameter / 2,
            length=handle_length,
            axis="z",
        ),
        "ferrule": Box(
            mass=ferrule_mass,
            center=np.array([0.0, 0.0, ferrule_start + ferrule_length / 2]),
            size=[bristle_thickness + 0.004, width + 0.004, ferrule_length],
        ),
        "bristles": Box(
            mass=bristle_mass,
            center=np.array([0.0, 0.0, bristles_start + bristle_length / 2]),
            size=[bristle_thickness, width, bristle_length],
        ),
    }
    return Tool(
        name=name,
        kind="brush",
        length=float(length),
        width=float(width),
        parts=parts,
        contact_point=np.array([0.0, 0.0, length]),
        contact_axis=np.array([0.0, 1.0, 0.0]),
        description=description,
    )
