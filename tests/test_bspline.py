"""The paper's quintic B-spline parameterisation: via points, rest at both ends, exact derivatives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lwrlab.io.exciting_motion import save_motion_description
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from plugins.trajectories.bspline import BSplineMotion


def bare_spline(duration: float) -> BSplineMotion:
    """The shipped ``bspline`` option (a via point every second) with no via points, lasting ``duration`` s."""
    return build("trajectory", "bspline", duration=duration, from_file=None)


def test_spline_passes_through_its_via_points_at_rest_at_both_ends(
    lwr4: RobotModel, rng: np.random.Generator
) -> None:
    spline = bare_spline(6.0)
    assert spline.n_coefficients == 7  # N_P = T_F + 1 via points, one per second
    via = spline.initial_coefficients(lwr4, rng, 0.5)
    q, dq, ddq = spline.evaluate(spline.via_times, via)
    np.testing.assert_allclose(q, via, atol=1e-12)
    np.testing.assert_allclose(dq[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(ddq[[0, -1]], 0.0, atol=1e-12)


def test_basis_derivatives_equal_central_differences_in_time() -> None:
    spline = bare_spline(5.0)
    t = np.linspace(0.05, 4.95, 37)
    h = 1e-5
    for derivative in (1, 2):
        numeric = (spline.basis(t + h, derivative - 1) - spline.basis(t - h, derivative - 1)) / (2 * h)
        np.testing.assert_allclose(
            spline.basis(t, derivative), numeric, rtol=1e-6, atol=1e-6 * np.abs(numeric).max()
        )


def test_motion_jacobian_is_the_basis(lwr4: RobotModel, rng: np.random.Generator) -> None:
    """Linear in the via points: the parameter Jacobian of q, q̇, q̈ is (B, Ḃ, B̈), checked by central differences."""
    spline = bare_spline(4.0)
    t = spline.times(100.0)
    via = spline.initial_coefficients(lwr4, rng, 0.4)
    bases = spline.bases(t)
    i, j, h = 2, 3, 1e-6
    plus, minus = via.copy(), via.copy()
    plus[i, j] += h
    minus[i, j] -= h
    for d, (a, b) in enumerate(zip(spline.evaluate(t, plus), spline.evaluate(t, minus), strict=True)):
        np.testing.assert_allclose((a - b)[:, j] / (2 * h), bases[d][:, i], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(np.delete(a - b, j, axis=1), 0.0, atol=1e-14)


def test_pull_back_is_the_adjoint_of_the_basis(rng: np.random.Generator) -> None:
    spline = bare_spline(3.0)
    bases = spline.bases(spline.times(100.0))
    c = rng.normal(size=(spline.n_coefficients, 7))
    grads = [rng.normal(size=(bases[0].shape[0], 7)) for _ in range(3)]
    lhs = sum(np.sum(g * (b @ c)) for g, b in zip(grads, bases, strict=True))
    np.testing.assert_allclose(np.sum(spline.pull_back(bases, *grads) * c), lhs, rtol=1e-12)


def test_round_trip_through_a_motion_file(tmp_path: Path, lwr4: RobotModel, rng: np.random.Generator) -> None:
    spline = bare_spline(3.0)
    motion = spline.with_coefficients(spline.initial_coefficients(lwr4, rng, 0.3))
    path = save_motion_description(motion.to_dict(), tmp_path / "motion.yaml", {"robot": lwr4.name})
    again = build("trajectory", "bspline", from_file=str(path))
    np.testing.assert_array_equal(again.sample(lwr4, 1000.0).q, motion.sample(lwr4, 1000.0).q)


def test_bad_inputs_are_refused(lwr4: RobotModel) -> None:
    with pytest.raises(ValueError, match="multiple of via_point_spacing"):
        bare_spline(2.5)
    with pytest.raises(ValueError, match="no coefficients"):
        bare_spline(2.0).sample(lwr4, 100.0)
    with pytest.raises(ValueError, match=r"\(3, N_J\)"):
        bare_spline(2.0).with_coefficients(np.zeros((4, 7)))
