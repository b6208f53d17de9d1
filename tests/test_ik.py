"""Analytic inverse geometric model with swivel angle (§II.B, eq. (1)) against forward kinematics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from lwrlab.kinematics import (
    BRANCHES,
    Branch,
    JointLimitViolation,
    SwivelIK,
    UnreachablePose,
    frame_pose,
    joint_frame_poses,
)


def _random_configurations(robot, rng, n):
    return rng.uniform(robot.limits.position_lower, robot.limits.position_upper, size=(n, robot.n_joints))


def test_batched_forward_kinematics_matches_pinocchio(lwr4, rng):
    q = _random_configurations(lwr4, rng, 20)
    poses = frame_pose(lwr4, q)
    data = lwr4.model.createData()
    flange = lwr4.model.getFrameId("flange")
    for k in range(q.shape[0]):
        pin.framesForwardKinematics(lwr4.model, data, q[k])
        np.testing.assert_allclose(poses[k], data.oMf[flange].homogeneous, atol=1e-14)


def test_fk_of_ik_is_the_pose_for_every_branch_and_random_swivel(lwr4, rng):
    ik = SwivelIK(lwr4)
    q = _random_configurations(lwr4, rng, 2000)
    poses = frame_pose(lwr4, q)
    low, high = ik.reach
    distance = np.linalg.norm(joint_frame_poses(lwr4, q)[4][:, :3, 3] - [0, 0, ik.shoulder_height], axis=1)
    keep = (distance > low + 1e-3) & (distance < high - 1e-3)  # away from the degenerate elbow circle
    poses = poses[keep]
    swivel = rng.uniform(-np.pi, np.pi, size=poses.shape[0])
    for branch in BRANCHES:
        solution = ik.solve_branch(poses, swivel, branch)
        np.testing.assert_allclose(frame_pose(lwr4, solution.q), poses, atol=1e-9)
        # the elbow is where eq. (1) puts it, whatever the branch
        np.testing.assert_allclose(ik.swivel_angle(solution.q), swivel, atol=1e-9)
        assert np.all(np.sign(np.sin(solution.q[:, [1, 3, 5]])) == np.array(branch))


def test_one_branch_recovers_the_original_configuration(lwr4, rng):
    ik = SwivelIK(lwr4)
    q = _random_configurations(lwr4, rng, 500)
    poses = frame_pose(lwr4, q)
    branches = [ik.solve_branch(poses, ik.swivel_angle(q), branch) for branch in BRANCHES]
    errors = np.stack([np.abs(np.angle(np.exp(1j * (s.q - q)))).max(axis=1) for s in branches])
    assert np.all(errors.min(axis=0) < 1e-8)


def test_unreachable_pose_and_joint_limit_give_clear_errors(lwr4):
    ik = SwivelIK(lwr4)
    far = np.eye(4)
    far[:3, 3] = [1.5, 0.0, 0.3]
    with pytest.raises(UnreachablePose, match="out of reach"):
        ik.solve(far[None], 0.0)
    q = np.array([[0.3, 0.8, 0.2, -1.2, 0.4, 1.0, 0.1]])
    pose = frame_pose(lwr4, q)
    phi = ik.swivel_angle(q)
    solutions = [ik.solve_branch(pose, phi, b) for b in BRANCHES]
    outside = next(s for s in solutions if not s.within_limits[0])
    with pytest.raises(JointLimitViolation, match=r"joint \d at"):
        ik.solve(pose, phi, outside.branch)


def test_rejects_robot_without_lwr4_structure(panda):
    with pytest.raises(ValueError, match="Table I"):
        SwivelIK(panda)


def test_branch_is_continuous_along_a_smooth_path(lwr4):
    ik = SwivelIK(lwr4)
    t = np.linspace(0, 1, 400)
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.4, 1.0, 0.1]) + 0.3 * np.sin(2 * np.pi * t)[:, None]
    pose = frame_pose(lwr4, q)
    solution = ik.solve(pose, ik.swivel_angle(q), Branch(1, -1, 1))
    assert np.abs(np.diff(solution.q, axis=0)).max() < 0.05
    np.testing.assert_allclose(solution.q, q, atol=1e-9)


def _painting_poses(n, rate=1000.0):
    """A vertical stroke of the roller's tool centre point on the wall at x = −0.8 m."""
    from lwrlab.planning.painting_path import PaintingPathParameters, sample_path

    path = sample_path(PaintingPathParameters(4.0, -1.6, 0.5, 0.25, 0.2, 0.1, 1), -0.8, rate)
    return path.poses()[:n]


def test_displaced_path_ik_follows_the_exact_ik_of_the_displaced_poses(lwr4, rng):
    """A slowly drifting offset (a force loop's integral, with a fast start) along x, then y too."""
    from lwrlab.kinematics import DisplacedPathIK

    tcp = np.eye(4)
    tcp[:3, 3] = [0.0, 0.0, 0.35]
    poses = _painting_poses(3000)
    ik = SwivelIK(lwr4)
    path_ik = DisplacedPathIK(ik, poses, tcp, -1.6, Branch(1, -1, -1))
    offsets = np.zeros((poses.shape[0], 3))
    offsets[:, 0] = (
        -0.01 * (1 - np.exp(-np.arange(poses.shape[0]) / 150.0))
        + np.cumsum(rng.normal(size=poses.shape[0])) * 2e-6
    )
    offsets[2000:, 1] = 1e-3 * np.sin(np.arange(1000) / 100.0)  # a second axis starts moving
    q = np.array([path_ik(k, offsets[k]) for k in range(poses.shape[0])])
    displaced = poses.copy()
    displaced[:, :3, 3] += offsets
    exact = ik.solve_branch(displaced @ np.linalg.inv(tcp), -1.6, Branch(1, -1, -1)).q
    assert np.abs(q - exact).max() < 5e-7  # ≈ 0.5 µm at the tool
    assert path_ik.solves < 200  # batched: far fewer IK calls than samples
    with pytest.raises(IndexError, match="outside"):
        path_ik(poses.shape[0], offsets[-1])


def test_path_batch_equals_each_path_followed_alone_and_the_exact_ik(lwr4, rng):
    """Three runs of one path with their own offsets (different drifts, one moving along y too) and
    two models: the stacked lookup gives each run what it alone gives, each within 5e-7 rad of the IK."""
    from lwrlab.kinematics import DisplacedPathIK
    from lwrlab.kinematics.displaced_path import DisplacedPathBatch
    from lwrlab.model.payload import attach_payload

    tcp = np.eye(4)
    tcp[:3, 3] = [0.0, 0.0, 0.35]
    poses = _painting_poses(1500)
    loaded = attach_payload(lwr4, np.array([1.2, 0.0, 0.0, 0.1, 0.02, 0.02, 0.0, 0.01, 0.0, 0.0]))
    iks = [SwivelIK(lwr4), SwivelIK(loaded), SwivelIK(lwr4)]
    n = poses.shape[0]
    offsets = np.zeros((3, n, 3))
    for r, (depth, rate) in enumerate([(0.01, 150.0), (0.004, 40.0), (0.02, 300.0)]):
        offsets[r, :, 0] = -depth * (1 - np.exp(-np.arange(n) / rate)) + np.cumsum(rng.normal(size=n)) * 2e-6
    offsets[1, 700:, 1] = 1e-3 * np.sin(np.arange(n - 700) / 100.0)

    def follow(ik):
        return DisplacedPathIK(ik, poses, tcp, -1.6, Branch(1, -1, -1))

    batch = DisplacedPathBatch([follow(ik) for ik in iks])
    stacked = np.array([batch(k, offsets[:, k]) for k in range(n)])  # (N, R, 7)
    for r, ik in enumerate(iks):
        alone = follow(ik)
        np.testing.assert_allclose(
            stacked[:, r], [alone(k, offsets[r, k]) for k in range(n)], rtol=0, atol=1e-12
        )
        displaced = poses.copy()
        displaced[:, :3, 3] += offsets[r]
        exact = ik.solve_branch(displaced @ np.linalg.inv(tcp), -1.6, Branch(1, -1, -1)).q
        assert np.abs(stacked[:, r] - exact).max() < 5e-7
    assert max(path.solves for path in batch.paths) < 100  # each path renews its own chunks only


def test_ik_derivatives_match_finite_differences(lwr4, rng):
    from lwrlab.kinematics.swivel_ik_derivatives import solve_branch_derivatives

    ik = SwivelIK(lwr4)
    q = _random_configurations(lwr4, rng, 300)
    poses, swivel = frame_pose(lwr4, q), ik.swivel_angle(q)
    h = 1e-6
    for branch in (Branch(1, 1, 1), Branch(1, -1, -1), Branch(-1, 1, -1)):
        solution, dq_dposition, dq_dswivel = solve_branch_derivatives(ik, poses, swivel, branch)
        np.testing.assert_array_equal(solution.q, ik.solve_branch(poses, swivel, branch).q)
        columns = []
        for axis in range(3):
            up, down = poses.copy(), poses.copy()
            up[:, axis, 3] += h
            down[:, axis, 3] -= h
            columns.append(
                (ik.solve_branch(up, swivel, branch).q - ik.solve_branch(down, swivel, branch).q) / (2 * h)
            )
        numeric = np.stack(columns, axis=2)
        numeric_swivel = (
            ik.solve_branch(poses, swivel + h, branch).q - ik.solve_branch(poses, swivel - h, branch).q
        ) / (2 * h)
        # away from the singularities, where finite differences are meaningful
        keep = np.all(solution.singularity_margin > 0.05, axis=1) & (np.abs(numeric).max(axis=(1, 2)) < 1e3)
        assert keep.sum() > 200
        scale = 1.0 + np.abs(numeric[keep]).max(axis=(1, 2), keepdims=True)  # per pose: large near the reach
        assert np.all(np.abs(dq_dposition[keep] - numeric[keep]) <= 1e-5 * scale)
        np.testing.assert_allclose(dq_dswivel[keep], numeric_swivel[keep], atol=1e-7)
