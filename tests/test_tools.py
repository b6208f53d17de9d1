"""Tool model: composite shapes → inertial parameters, frame changes, attachment to a robot, library."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from lwrlab.dynamics.regressor import regressor
from lwrlab.model.inertia import inertia_matrix, is_physically_consistent, random_consistent_parameters
from lwrlab.model.payload import (
    attach_payload,
    change_frame,
    flange_placement,
    frame_change_matrix,
    payload_in_joint_frame,
)
from lwrlab.pipeline.build import build
from lwrlab.pipeline.tools.library import build_tool, load_library, load_tool, tool_names
from lwrlab.tools.library import PAPER_TOOLS
from lwrlab.tools.model import composite_tool
from lwrlab.tools.shapes import Box, Cylinder, Sphere


def _sampled_inertia(points: np.ndarray, mass: float, center: np.ndarray) -> np.ndarray:
    """Standard parameters of a cloud of equal point masses (Monte-Carlo check of the formulas).

    The cloud (about ``center``) is mirrored in the three coordinate planes through ``center``, so
    its first moment and products of inertia are exact and only the diagonal carries sampling noise.
    """
    offsets = points - center
    points = (
        np.concatenate(
            [offsets * np.array([sx, sy, sz]) for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]
        )
        + center
    )
    m = mass / len(points)
    r2 = np.sum(points**2, axis=1)
    inertia = m * (np.sum(r2) * np.eye(3) - points.T @ points)
    return np.array(
        [
            mass,
            *(m * points.sum(axis=0)),
            inertia[0, 0],
            inertia[1, 1],
            inertia[2, 2],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 2],
        ]
    )


def test_shapes_match_a_sampled_solid(rng: np.random.Generator) -> None:
    n = 100_000
    center = np.array([0.01, -0.02, 0.2])
    # tube along y: radius uniform in area between r and R, angle uniform, height uniform
    r_in, r_out, h = 0.02, 0.025, 0.2
    radius = np.sqrt(rng.uniform(r_in**2, r_out**2, n))
    angle = rng.uniform(0, 2 * np.pi, n)
    points = (
        np.column_stack([radius * np.cos(angle), rng.uniform(-h / 2, h / 2, n), radius * np.sin(angle)])
        + center
    )
    tube = Cylinder(mass=0.08, center=center, radius=r_out, length=h, axis="y", inner_radius=r_in)
    np.testing.assert_allclose(
        tube.parameters(), _sampled_inertia(points, 0.08, center), rtol=5e-3, atol=1e-12
    )
    size = np.array([0.015, 0.1, 0.06])
    points = rng.uniform(-size / 2, size / 2, (n, 3)) + center
    box = Box(mass=0.06, center=center, size=size)
    np.testing.assert_allclose(
        box.parameters(), _sampled_inertia(points, 0.06, center), rtol=5e-3, atol=1e-12
    )
    ball = rng.normal(size=(n, 3))
    ball *= (0.03 * rng.uniform(0, 1, n) ** (1 / 3) / np.linalg.norm(ball, axis=1))[:, None]
    np.testing.assert_allclose(
        Sphere(mass=0.1, center=center, radius=0.03).parameters(),
        _sampled_inertia(ball + center, 0.1, center),
        rtol=5e-3,
        atol=1e-12,
    )


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="inner radius"):
        Cylinder(mass=0.1, center=[0, 0, 0], radius=0.01, length=0.1, inner_radius=0.02)
    with pytest.raises(ValueError, match="mass"):
        Box(mass=-1.0, center=[0, 0, 0], size=[0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match=r"unknown shape 'cone'.*valid shapes"):
        composite_tool("x", "probe", 0.1, 0.01, {"tip": {"shape": "cone", "mass": 0.1, "center": [0, 0, 0]}})


def test_change_frame_agrees_with_pinocchio_and_is_linear(rng: np.random.Generator) -> None:
    phi = random_consistent_parameters(rng, scale_m=0.1, mass_kg=0.3)
    placement = pin.SE3.Random()
    expected = placement.act(pin.Inertia.FromDynamicParameters(phi[[0, 1, 2, 3, 4, 7, 5, 8, 9, 6]]))
    moved = change_frame(phi, placement.rotation, placement.translation)
    np.testing.assert_allclose(
        moved[[0, 1, 2, 3, 4, 7, 5, 8, 9, 6]], expected.toDynamicParameters(), atol=1e-12
    )
    matrix = frame_change_matrix(placement.rotation, placement.translation)
    np.testing.assert_allclose(matrix @ phi, moved, atol=1e-12)
    back = change_frame(moved, placement.rotation.T, -placement.rotation.T @ placement.translation)
    np.testing.assert_allclose(back, phi, atol=1e-12)


def test_attached_tool_changes_only_the_last_segment_and_the_torques(lwr4, rng: np.random.Generator) -> None:
    tool = load_tool("large_roller")
    loaded = attach_payload(lwr4, tool.parameters)
    joint, placement = flange_placement(lwr4)
    assert joint == 7 and np.allclose(placement.translation, [0, 0, 0.078])
    difference = loaded.link_parameters - lwr4.link_parameters
    np.testing.assert_allclose(difference[:6], 0.0, atol=1e-15)
    _, phi7 = payload_in_joint_frame(lwr4, tool.parameters)
    np.testing.assert_allclose(difference[6], phi7, atol=1e-12)
    assert phi7[3] == pytest.approx(tool.mass * (0.078 + tool.center_of_mass[2]))
    assert is_physically_consistent(loaded.link_parameters[6])
    # the extra torque is the last segment's regressor times the tool's frame-7 parameters
    q = rng.uniform(lwr4.limits.position_lower, lwr4.limits.position_upper, (20, 7))
    dq, ddq = rng.normal(size=(20, 7)), rng.normal(size=(20, 7))
    extra = (loaded.inverse_dynamics(q, dq, ddq) - lwr4.inverse_dynamics(q, dq, ddq)).ravel()
    np.testing.assert_allclose(extra, regressor(lwr4, q, dq, ddq)[:, 60:70] @ phi7, atol=1e-10)


def test_library_holds_the_paper_rollers_and_eight_more() -> None:
    library = load_library()
    assert set(PAPER_TOOLS) <= set(library.names) and len(library) >= 10
    large, small = library["large_roller"], library["small_roller"]
    assert (large.length, large.width, large.mass) == pytest.approx((0.35, 0.20, 0.2))
    assert (small.length, small.width, small.mass) == pytest.approx((0.33, 0.10, 0.1))
    assert {"roller", "brush"} <= set(library.kinds)
    for tool in library:
        assert is_physically_consistent(tool.parameters), tool.name
        # the contact line is the far end of the tool
        assert tool.contact_point[2] == pytest.approx(tool.length)
        assert np.all(np.linalg.eigvalsh(inertia_matrix(tool.parameters)) > 0)
    # every pair of tools differs in its inertial parameters (a look-up table can tell them apart)
    parameters = library.parameters
    gaps = np.linalg.norm(parameters[:, None] - parameters[None], axis=2) + np.eye(len(library))
    assert gaps.min() > 1e-3


def test_library_errors_name_the_valid_choices(tmp_path) -> None:
    with pytest.raises(KeyError, match="large_roller"):
        load_tool("no_such_tool")
    (tmp_path / "bad.yaml").write_text(
        "_target_: lwrlab.tools.painting.paint_roller\nname: bad\nlength: 0.3\n"
    )
    with pytest.raises(ValueError, match=r"bad\.yaml: bad arguments"):
        load_tool("bad", tmp_path)
    with pytest.raises(ValueError, match="_target_"):
        build_tool({"name": "x"})
    assert tool_names(tmp_path) == ["bad"]


def test_a_tool_described_part_by_part_round_trips(tmp_path) -> None:
    (tmp_path / "probe.yaml").write_text(
        "_target_: lwrlab.tools.model.composite_tool\nname: probe\nkind: probe\nlength: 0.2\nwidth: 0.01\n"
        "parts:\n  rod: {shape: cylinder, mass: 0.1, center: [0, 0, 0.1], radius: 0.005, length: 0.2}\n"
        "  tip: {shape: sphere, mass: 0.05, center: [0, 0, 0.2], radius: 0.01}\n"
    )
    probe = load_tool("probe", tmp_path)
    assert probe.mass == pytest.approx(0.15)
    assert probe.parameters[3] == pytest.approx(0.1 * 0.1 + 0.05 * 0.2)


def test_tool_excitation_criterion_gradient_and_choice(lwr4, rng: np.random.Generator) -> None:
    from lwrlab.tools.excitation import ToolLogDet, select_tool_motion

    w = rng.normal(size=(40, 10))
    value, gradient = ToolLogDet().value_and_gradient(w)
    step = 1e-6
    for i, j in [(0, 0), (5, 3), (39, 9)]:
        shifted = w.copy()
        shifted[i, j] += step
        assert (ToolLogDet().value_and_gradient(shifted)[0] - value) / step == pytest.approx(
            gradient[i, j], rel=1e-4
        )
    motions = [
        build("trajectory", "multisine", duration=2.0, harmonics=4, seed=s).sample(lwr4, 100.0)
        for s in range(3)
    ]
    still = build("trajectory", "multisine", duration=2.0, harmonics=4, seed=0, limit_fraction=0.05)
    motions.insert(0, still.sample(lwr4, 100.0))  # barely moves: excites nothing
    best, values = select_tool_motion(lwr4, motions)
    assert best != 0 and values[0] > values.min() + 1.0


def test_tool_motion_candidates_start_at_the_yaml_seed_and_need_one(lwr4) -> None:
    """The loaded-motion candidates are seeded from the motion node's own ``seed``; a node without
    one is refused (no silent seed 0)."""
    from functools import partial

    from lwrlab.errors import ConfigError
    from lwrlab.pipeline.tools.bench import tool_motion
    from plugins.trajectories.multisine import MultisineMotion

    settings = build("trajectory", "multisine", duration=2.0, harmonics=3)
    node = {name: getattr(settings, name) for name in ("duration", "harmonics", "limit_fraction", "center")}
    _, table = tool_motion(partial(MultisineMotion, **node, seed=7), 2, lwr4, 100.0)
    assert table["seed"].tolist() == [7, 8]
    with pytest.raises(ConfigError, match="seed"):
        tool_motion(partial(MultisineMotion, **node), 2, lwr4, 100.0)
