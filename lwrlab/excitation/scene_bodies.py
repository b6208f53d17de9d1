"""What a collision scene is made of: the enclosing spheres of the robot's links, and its fixed
primitives (a table, a stand) as world objects (:mod:`lwrlab.excitation.collision_scene`)."""

from __future__ import annotations

import numpy as np

from lwrlab.model.collision import CollisionSphere
from lwrlab.model.collision_geometry import CollisionShape, RobotGeometry
from lwrlab.model.enclosing_spheres import enclosing_spheres
from lwrlab.model.world import WorldObject


def fitted_spheres(geometry: RobotGeometry, links: list[str]) -> list[CollisionSphere]:
    """The enclosing spheres of each link: its round primitives as they are, its other shapes covered
    together (:func:`~lwrlab.model.enclosing_spheres.enclosing_spheres`), in their joint's frame."""
    spheres = []
    for link in links:
        shapes = geometry.shapes_of(link)
        round_shapes = [s for s in shapes if s.sphere_radius is not None]
        spheres += [
            CollisionSphere(
                f"{link}#{s.name}", s.joint, s.placement[:3, 3].copy(), float(s.sphere_radius), link
            )
            for s in round_shapes
            if s.sphere_radius is not None
        ]
        others = [s for s in shapes if s.sphere_radius is None]
        if not others:
            continue
        vertices = np.vstack([s.vertices_in_joint_frame() for s in others])
        offsets = np.cumsum([0] + [len(s.vertices) for s in others[:-1]])
        faces = np.vstack([s.faces + o for s, o in zip(others, offsets, strict=True)])
        centres, radii = enclosing_spheres(vertices, faces)
        spheres += [
            CollisionSphere(f"{link}#{i}", others[0].joint, c, float(r), link)
            for i, (c, r) in enumerate(zip(centres, radii, strict=True))
        ]
    return spheres


def world_from_shapes(shapes: tuple[CollisionShape, ...]) -> list[WorldObject]:
    """Primitive shapes fixed to the base (a table, a stand) as world objects."""
    objects = []
    for shape in shapes:
        kind = type(shape.geometry).__name__
        vertices = shape.vertices_in_joint_frame()
        common = {
            "pose": shape.placement,
            "geometry": shape.geometry,
            "vertices": vertices,
            "faces": shape.faces,
        }
        if kind == "Box":
            objects.append(WorldObject(shape.link, "box", size=np.asarray(shape.geometry.halfSide), **common))
        elif kind == "Sphere":
            objects.append(
                WorldObject(shape.link, "sphere", size=np.array([shape.geometry.radius]), **common)
            )
        elif kind == "Cylinder":
            size = np.array([shape.geometry.radius, shape.geometry.halfLength])
            objects.append(WorldObject(shape.link, "cylinder", size=size, **common))
    names = [o.name for o in objects]
    return [
        WorldObject(**{**o.__dict__, "name": f"{o.name} ({i})" if names.count(o.name) > 1 else o.name})
        for i, o in enumerate(objects)
    ]
