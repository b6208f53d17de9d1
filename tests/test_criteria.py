"""Criterion plugins: gradients against central differences, invariants, a criterion from outside lwrlab."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
from composing import CONF, compose_config
from hydra.utils import instantiate

from lwrlab.excitation.criteria import Criterion

CRITERIA = sorted(p.stem for p in (CONF / "criterion").glob("*.yaml"))


def build(name: str) -> Criterion:
    cfg = compose_config(f"criterion={name}")
    return instantiate(cfg.criterion)


def regressor_like(rng: np.random.Generator, rows: int = 60, columns: int = 6) -> np.ndarray:
    """A full-rank matrix with unequal, correlated columns (like a base regressor)."""
    return (
        rng.normal(size=(rows, columns))
        @ (np.eye(columns) + 0.3 * rng.normal(size=(columns, columns)))
        * rng.uniform(0.5, 3.0, columns)
    )


def central_difference_gradient(criterion: Criterion, w: np.ndarray, h: float = 1e-6) -> np.ndarray:
    numeric = np.zeros_like(w)
    for index in np.ndindex(*w.shape):
        plus, minus = w.copy(), w.copy()
        plus[index] += h
        minus[index] -= h
        numeric[index] = (criterion.value_and_gradient(plus)[0] - criterion.value_and_gradient(minus)[0]) / (
            2 * h
        )
    return numeric


def test_the_paper_criteria_and_the_extensions_are_plugins() -> None:
    assert {"cond", "logdet", "hadamard", "logcond", "a_optimality", "e_optimality"} <= set(CRITERIA)


@pytest.mark.parametrize("name", CRITERIA)
def test_gradient_equals_central_differences(name: str, rng: np.random.Generator) -> None:
    criterion = build(name)
    assert criterion.name == name
    w = regressor_like(rng)
    value, gradient = criterion.value_and_gradient(w)
    assert np.isfinite(value) and gradient.shape == w.shape
    numeric = central_difference_gradient(criterion, w)
    assert np.abs(gradient - numeric).max() <= 1e-6 * np.abs(numeric).max()


@pytest.mark.parametrize("name", CRITERIA)
def test_more_excitation_is_better(name: str, rng: np.random.Generator) -> None:
    """Appending rows (a longer motion) never worsens logdet/hadamard/A/E; doubling W never changes cond."""
    criterion = build(name)
    w = regressor_like(rng)
    value = criterion.value_and_gradient(w)[0]
    if name in ("cond", "logcond"):
        assert value >= (1.0 if name == "cond" else 0.0)
        assert criterion.value_and_gradient(2.0 * w)[0] == pytest.approx(value, rel=1e-10)
    else:
        assert criterion.value_and_gradient(np.vstack([w, regressor_like(rng)]))[0] < value


@pytest.mark.parametrize("name", ["logdet", "hadamard"])
def test_column_scaling_shifts_logdet_and_hadamard_by_a_constant(name: str, rng: np.random.Generator) -> None:
    criterion = build(name)
    scale = rng.uniform(0.1, 10.0, 6)
    a, b = regressor_like(rng), regressor_like(rng)
    shift_a = criterion.value_and_gradient(a * scale)[0] - criterion.value_and_gradient(a)[0]
    shift_b = criterion.value_and_gradient(b * scale)[0] - criterion.value_and_gradient(b)[0]
    assert shift_a == pytest.approx(-2.0 * np.sum(np.log(scale)), rel=1e-9)
    assert shift_a == pytest.approx(shift_b, rel=1e-9)


@pytest.mark.parametrize("name", CRITERIA)
def test_rank_deficient_regressor_is_refused(name: str, rng: np.random.Generator) -> None:
    w = regressor_like(rng)
    w[:, 2] = 0.0
    with pytest.raises(np.linalg.LinAlgError, match="excite"):
        build(name).value_and_gradient(w)


def test_a_criterion_from_outside_the_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lwr4) -> None:
    """A user adds a criterion (a module and a YAML in their own directory), found by hydra.searchpath."""
    (tmp_path / "my_criteria.py").write_text(
        textwrap.dedent(
            '''
            import numpy as np

            class InverseTrace:
                """J = trace((WᵀW)⁻¹)·weight (A-optimality without the log)."""
                name = "inverse_trace"

                def __init__(self, weight: float = 1.0):
                    self.weight = weight

                def value_and_gradient(self, w):
                    inverse = np.linalg.inv(w.T @ w)
                    return self.weight * float(np.trace(inverse)), -2.0 * self.weight * w @ inverse @ inverse
            '''
        )
    )
    (tmp_path / "conf" / "criterion").mkdir(parents=True)
    (tmp_path / "conf" / "criterion" / "inverse_trace.yaml").write_text(
        "_target_: my_criteria.InverseTrace\nweight: 2.0\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    cfg = compose_config(
        f"hydra.searchpath=[file://{tmp_path / 'conf'}]",
        "criterion=inverse_trace",
        "trajectory=optimal",
        "trajectory.duration=2.0",
    )
    criterion = instantiate(cfg.criterion)
    assert criterion.name == "inverse_trace" and criterion.weight == 2.0
    # the optimal-motion plugin picks it up through ${criterion}; the problem's gradient chain works with it
    source = instantiate(cfg.trajectory)
    assert source.criterion.name == "inverse_trace"
    problem = source.problem(lwr4)
    x = problem.parameterisation.initial_coefficients(lwr4, np.random.default_rng(0), 0.4).ravel()
    gradient = problem.objective_gradient(x)
    h = 1e-6
    e = np.zeros_like(x)
    e[5] = 1.0
    numeric = (problem.objective(x + h * e) - problem.objective(x - h * e)) / (2 * h)
    assert gradient[5] == pytest.approx(numeric, rel=1e-5)


@pytest.mark.parametrize("sharpness", [None, 4.0, 32.0])
def test_cond_gradient_equals_central_differences_smooth_or_exact(
    sharpness: float | None, rng: np.random.Generator
) -> None:
    from plugins.criteria.cond import ConditionNumber

    criterion = ConditionNumber(sharpness=sharpness)
    w = regressor_like(rng)
    gradient = criterion.value_and_gradient(w)[1]
    numeric = central_difference_gradient(criterion, w)
    assert np.abs(gradient - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_smooth_cond_brackets_cond_and_tends_to_it(rng: np.random.Generator) -> None:
    """cond ≤ J_p ≤ N_B^(1/p)·cond, and J_p → cond as p grows."""
    from plugins.criteria.cond import ConditionNumber

    w = regressor_like(rng, columns=8)
    exact = float(np.linalg.cond(w))
    assert ConditionNumber(sharpness=None).value_and_gradient(w)[0] == pytest.approx(exact, rel=1e-12)
    gaps = []
    for p in (2.0, 8.0, 32.0, 128.0):
        value = ConditionNumber(sharpness=p).value_and_gradient(w)[0]
        assert exact * (1 - 1e-12) <= value <= exact * 8 ** (1 / p) * (1 + 1e-12)
        gaps.append(value / exact - 1.0)
    assert gaps == sorted(gaps, reverse=True) and gaps[-1] < 0.02


def test_smooth_cond_is_smooth_where_the_smallest_singular_values_coincide() -> None:
    """A double σ_min: the exact ratio has a kink there (one-sided slopes differ), the smooth one does not."""
    from plugins.criteria.cond import ConditionNumber

    w = np.diag([3.0, 1.0, 1.0])
    direction = np.diag([0.0, 1.0, -1.0])
    h = 1e-5

    def one_sided_slopes(criterion: ConditionNumber) -> tuple[float, float]:
        at = criterion.value_and_gradient(w)[0]
        return (criterion.value_and_gradient(w + h * direction)[0] - at) / h, (
            at - criterion.value_and_gradient(w - h * direction)[0]
        ) / h

    right, left = one_sided_slopes(ConditionNumber(sharpness=None))
    kink = right - left
    assert kink > 1.0
    right, left = one_sided_slopes(ConditionNumber(sharpness=32.0))
    assert abs(right - left) < 1e-2 * kink  # O(h·curvature), not O(1)
