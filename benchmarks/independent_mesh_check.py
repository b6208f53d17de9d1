"""An exact-mesh check of a motion that shares no code with lwrlab: Pinocchio's URDF and SRDF parsers,
``computeCollisions`` on the collision meshes, the lowest surface point above the mounting surface.

Used by ``benchmarks/own_robot_motion.py`` and by the slow tests of ``tests/test_own_robot_motion.py``
(loaded by path). Pairs are chosen as MoveIt's setup assistant does: an SRDF's disabled pairs, links
on one joint or on neighbouring joints, and pairs in contact in 95 % of random poses are not checked.
A continuous joint stays Pinocchio's own ``RevoluteUnbounded`` joint here, configured by the cosine and
sine of the motion's angle (lwrlab reads it as a revolute joint, one angle).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pinocchio as pin


def surface_points(geometry: object) -> np.ndarray:
    """Points whose lowest is the shape's lowest (shape frame): a mesh's vertices, a box's corners, 256
    points on a cylinder's rims or on a sphere's great circles (within 0.01 % of the radius)."""
    if hasattr(geometry, "vertices"):
        return np.asarray(geometry.vertices())
    if hasattr(geometry, "halfSide"):
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * geometry.halfSide
    angle = np.linspace(0.0, 2 * np.pi, 256, endpoint=False)
    circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(256)])
    if hasattr(geometry, "halfLength"):
        return np.vstack(
            [geometry.radius * circle + [0.0, 0.0, z] for z in (-geometry.halfLength, geometry.halfLength)]
        )
    return geometry.radius * np.vstack([circle[:, order] for order in ([0, 1, 2], [0, 2, 1], [2, 0, 1])])


def configuration(model: pin.Model, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration of one angle (or position) per degree of freedom: (cos, sin) for an
    unbounded revolute joint (nq = 2, nv = 1)."""
    if model.nq == model.nv:
        return angles
    q = np.empty(model.nq)
    for joint in model.joints[1:]:
        value = angles[joint.idx_v]
        if joint.nq == 2 and joint.nv == 1:
            q[joint.idx_q : joint.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            q[joint.idx_q] = value
    return q


def random_angles(model: pin.Model, rng: np.random.Generator) -> np.ndarray:
    """One angle per degree of freedom, uniform in the limits (one turn for an unbounded joint)."""
    if model.nq == model.nv:
        return rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
    angles = np.empty(model.nv)
    for joint in model.joints[1:]:
        if joint.nq == 2 and joint.nv == 1:
            angles[joint.idx_v] = rng.uniform(-np.pi, np.pi)
        else:
            angles[joint.idx_v] = rng.uniform(
                model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            )
    return angles


def independent_check(
    urdf: str | Path,
    package_dir: str | Path,
    q: np.ndarray,
    clearance: float,
    srdf: str | Path | None = None,
    locked_joints: Mapping[str, float] | None = None,
) -> tuple[int, int, float]:
    """Poses of q (N, N_J) in self-contact (padding = clearance), poses whose links beyond the first
    come within the clearance of the z = 0 plane, and the lowest point of those links (m)."""
    model = pin.buildModelFromUrdf(str(urdf))
    geometry = pin.buildGeomFromUrdf(
        model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(package_dir)]
    )
    if locked_joints:
        reference = pin.neutral(model)
        for joint, value in locked_joints.items():
            reference[model.joints[model.getJointId(joint)].idx_q] = value
        ids = [model.getJointId(j) for j in locked_joints]
        model, geometry = pin.buildReducedModel(model, geometry, ids, reference)
    geometry.addAllCollisionPairs()
    if srdf is not None:
        pin.removeCollisionPairs(model, geometry, str(srdf))
    for k in reversed(range(len(geometry.collisionPairs))):  # neighbours touch at their joint
        pair = geometry.collisionPairs[k]
        a = geometry.geometryObjects[pair.first].parentJoint
        b = geometry.geometryObjects[pair.second].parentJoint
        if a == b or model.parents[a] == b or model.parents[b] == a:
            geometry.removeCollisionPair(pair)
    data, geometry_data = model.createData(), geometry.createData()
    rng = np.random.default_rng(1)
    always = np.zeros(len(geometry.collisionPairs))
    for _ in range(100):  # the robot's own structure
        pose = configuration(model, random_angles(model, rng))
        pin.computeCollisions(model, data, geometry, geometry_data, pose, False)
        always += [r.isCollision() for r in geometry_data.collisionResults]
    for k in reversed(np.flatnonzero(always >= 95)):
        geometry.removeCollisionPair(geometry.collisionPairs[int(k)])
    geometry_data = geometry.createData()
    for request in geometry_data.collisionRequests:
        request.security_margin = clearance
    points = {
        i: surface_points(obj.geometry)
        for i, obj in enumerate(geometry.geometryObjects)
        if model.parents[obj.parentJoint] > 0  # the links beyond the first (it stands on the surface)
    }
    in_contact = below = 0
    lowest = np.inf
    for k in range(q.shape[0]):
        pin.computeCollisions(model, data, geometry, geometry_data, configuration(model, q[k]), False)
        in_contact += any(r.isCollision() for r in geometry_data.collisionResults)
        low = np.inf
        for i, local in points.items():
            placement = geometry_data.oMg[i]
            low = min(low, float((local @ placement.rotation.T + placement.translation)[:, 2].min()))
        lowest = min(lowest, low)
        below += low < clearance
    return in_contact, below, lowest
