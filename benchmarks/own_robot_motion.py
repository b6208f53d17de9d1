"""Exciting motions for robots nobody here wrote, each checked independently against its own meshes.

For every arm of ``example-robot-data`` that ``robot=example_robot`` loads (Panda with hand and SRDF,
UR3/UR5/UR10, xArm7, Z1) it optimises the default 10 s ``logdet`` exciting motion with every
constraint (limits, torques, self-collision, the mounting surface), one start, and reports:

* the optimiser's wall time and cond(W_b) of the optimum;
* the same motion optimised **without** collision constraints (self_collision off, no world): its
  cond(W_b) is the baseline the collision-free motion is compared with (the ratio);
* lwrlab's own exact 1 kHz check (closest approach to itself and to the world, its time);
* an **independent** check that shares no code with lwrlab's: Pinocchio's URDF and SRDF parsers,
  ``pin.computeCollisions`` on the URDF's collision meshes at every 1 kHz sample (padding = the
  clearance), and the lowest mesh vertex above the mounting surface — poses in contact counted.

Usage::

    .venv/bin/python benchmarks/own_robot_motion.py [--robots panda ur5] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pinocchio as pin

from lwrlab.excitation.solver import check_motion_at
from lwrlab.pipeline.build import build
from lwrlab.pipeline.excitation import regressor_condition
from plugins.robots.example_robot import ROBOTS, example_robot_file

DEFAULT_ACCELERATION = 10.0
"""rad/s² where the manufacturer publishes none."""


def _surface_points(geometry: object) -> np.ndarray:
    """Points whose lowest is the shape's lowest: a mesh's vertices, a box's corners, 256 points on a
    cylinder's rims or a sphere's great circles (within 0.01 % of the radius)."""
    if hasattr(geometry, "vertices"):
        return np.asarray(geometry.vertices())
    if hasattr(geometry, "halfSide"):
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * geometry.halfSide
    angle = np.linspace(0.0, 2 * np.pi, 256, endpoint=False)
    circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(256)])
    if hasattr(geometry, "halfLength"):
        rims = [geometry.radius * circle + [0.0, 0.0, z] for z in (-geometry.halfLength, geometry.halfLength)]
        return np.vstack(rims)
    return geometry.radius * np.vstack([circle[:, order] for order in ([0, 1, 2], [0, 2, 1], [2, 0, 1])])


def independent_check(name: str, q: np.ndarray, clearance: float) -> tuple[int, int, float]:
    """Poses (of q (N, N_J)) in self-contact and below the mounting surface z = 0, and the lowest
    mesh point (m), from the robot's own files through Pinocchio alone."""
    entry = ROBOTS[name]
    urdf = example_robot_file(entry.urdf)
    share = urdf[: urdf.index("/example-robot-data/")]
    model = pin.buildModelFromUrdf(urdf)
    geometry = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.COLLISION, package_dirs=[share])
    if entry.locked_joints:
        q_ref = pin.neutral(model)
        for joint, value in entry.locked_joints.items():
            q_ref[model.joints[model.getJointId(joint)].idx_q] = value
        ids = [model.getJointId(j) for j in entry.locked_joints]
        model, geometry = pin.buildReducedModel(model, geometry, ids, q_ref)
    geometry.addAllCollisionPairs()
    if entry.srdf is not None:
        pin.removeCollisionPairs(model, geometry, example_robot_file(entry.srdf))
    # neighbours (a joint and its parent) touch at their joint: MoveIt's "adjacent"
    for k in reversed(range(len(geometry.collisionPairs))):
        pair = geometry.collisionPairs[k]
        a = geometry.geometryObjects[pair.first].parentJoint
        b = geometry.geometryObjects[pair.second].parentJoint
        if a == b or model.parents[a] == b or model.parents[b] == a:
            geometry.removeCollisionPair(pair)
    data, geometry_data = model.createData(), geometry.createData()
    for request in geometry_data.collisionRequests:
        request.security_margin = clearance
    # pairs in contact in the robot's every random pose are its structure (MoveIt's "always")
    rng = np.random.default_rng(1)
    always = np.zeros(len(geometry.collisionPairs))
    for _ in range(200):
        pin.computeCollisions(
            model,
            data,
            geometry,
            geometry_data,
            rng.uniform(model.lowerPositionLimit, model.upperPositionLimit),
            False,
        )
        always += [r.isCollision() for r in geometry_data.collisionResults]
    for k in reversed(np.flatnonzero(always >= 190)):
        geometry.removeCollisionPair(geometry.collisionPairs[int(k)])
    geometry_data = geometry.createData()
    for request in geometry_data.collisionRequests:
        request.security_margin = clearance
    vertices = {
        i: _surface_points(obj.geometry) @ obj.placement.rotation.T + obj.placement.translation
        for i, obj in enumerate(geometry.geometryObjects)
        if obj.parentJoint > 0
    }
    self_contacts = below = 0
    lowest = np.inf
    for k in range(q.shape[0]):
        pin.computeCollisions(model, data, geometry, geometry_data, q[k], False)
        self_contacts += any(r.isCollision() for r in geometry_data.collisionResults)
        heights = [
            (data.oMi[geometry.geometryObjects[i].parentJoint].rotation @ v.T)[2].min()
            + data.oMi[geometry.geometryObjects[i].parentJoint].translation[2]
            for i, v in vertices.items()
            if model.parents[geometry.geometryObjects[i].parentJoint] != 0  # the first link stands on it
        ]
        low = min(heights)
        lowest = min(lowest, low)
        below += low < clearance
    return self_contacts, below, float(lowest)


def measure(name: str, seed: int) -> dict[str, object]:
    entry = ROBOTS[name]
    acceleration = None if entry.acceleration_limits is not None else DEFAULT_ACCELERATION
    robot = build("robot", "example_robot", robot_name=name, acceleration_limits=acceleration)
    optimizer = build("optimizer", "slsqp", show_progress=False, seed=seed)
    source = build("trajectory", "optimal", from_file=None, optimizer=optimizer)
    clock = time.perf_counter()
    motion, result, problem = source.optimise(robot)
    optimise_s = time.perf_counter() - clock
    check = check_motion_at(robot, motion, source.constraints, 1000.0)
    q, dq, ddq = (b @ result.coefficients for b in problem.bases)
    cond = regressor_condition(robot, q, dq, ddq, problem.base)
    free_constraints = {"self_collision": False, "world": {"mounting_surface": None, "obstacles": []}}
    free_source = build(
        "trajectory", "optimal", from_file=None, optimizer=optimizer, constraints=free_constraints
    )
    free_motion, free_result, free_problem = free_source.optimise(robot)
    fq, fdq, fddq = (b @ free_result.coefficients for b in free_problem.bases)
    free_cond = regressor_condition(robot, fq, fdq, fddq, free_problem.base)
    sampled = motion.sample(robot, 1000.0)
    self_contacts, below, lowest = independent_check(name, sampled.q, source.constraints.clearance)
    collisions = check.collisions
    assert collisions is not None
    closest_self, closest_world = collisions.closest("self"), collisions.closest("world")
    return {
        "robot": name,
        "joints": robot.n_joints,
        "optimiser [s]": round(optimise_s, 1),
        "cond": round(cond, 2),
        "cond without collisions": round(free_cond, 2),
        "ratio": round(cond / free_cond, 3),
        "closest to itself [mm]": round(1000 * closest_self.distance, 1) if closest_self else None,
        "closest to the world [mm]": round(1000 * closest_world.distance, 1) if closest_world else None,
        "check [s]": round(collisions.seconds, 2),
        "accepted": check.passed,
        "independent: poses in self-contact": self_contacts,
        "independent: poses below the surface": below,
        "independent: lowest point [mm]": round(1000 * lowest, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robots", nargs="*", default=sorted(ROBOTS))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    import pandas as pd

    rows = []
    for name in args.robots:
        print(f"{name} …", flush=True)
        rows.append(measure(name, args.seed))
        print(pd.DataFrame(rows[-1:]).to_markdown(index=False), flush=True)
    print("\n## Exciting motions of robots nobody here wrote\n")
    print(pd.DataFrame(rows).to_markdown(index=False))


if __name__ == "__main__":
    main()
