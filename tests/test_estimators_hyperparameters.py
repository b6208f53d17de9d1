"""scikit-learn's parameter protocol without scikit-learn (lwrlab/identification/hyperparameters.py),
and its use by the block bootstrap (refits of clones, the context resampled with the rows)."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.identification.bootstrap import block_bootstrap
from lwrlab.identification.hyperparameters import HyperParameters, clone_estimator
from lwrlab.pipeline.build import build


class Scaled(HyperParameters):
    """A composite: an inner estimator and a setting of its own."""

    def __init__(self, *, inner: object, factor: float) -> None:
        self.inner = inner
        self.factor = factor


def test_nested_parameters_read_and_set_as_name__key() -> None:
    composite = Scaled(inner=build("estimator", "wls", n_joints=2), factor=2.0)
    params = composite.get_params()
    assert params["factor"] == 2.0 and params["inner__n_joints"] == 2 and params["inner__reweight_steps"] == 2
    assert "inner__n_joints" not in composite.get_params(deep=False)
    composite.set_params(inner__reweight_steps=5, factor=3.0)
    assert composite.inner.reweight_steps == 5 and composite.factor == 3.0
    with pytest.raises(ValueError, match="valid: \\['factor', 'inner'\\]"):
        composite.set_params(scale=1.0)


def test_clone_copies_settings_deeply_and_drops_what_was_learned(rng: np.random.Generator) -> None:
    inner = build("estimator", "wls", n_joints=2).fit(rng.normal(size=(40, 2)), rng.normal(size=40))
    bounds = [0.5, 2.0]
    composite = Scaled(inner=inner, factor=bounds)
    copy = clone_estimator(composite)
    assert copy.factor == bounds and copy.factor is not bounds  # a copy, not the same list
    assert copy.inner is not inner and copy.inner.get_params() == inner.get_params()
    assert not hasattr(copy.inner, "phi_")  # the nested estimator is cloned too: unfitted


def test_repr_names_every_setting_but_unchanged_constants() -> None:
    """A plugin's settings have no Python default (the YAML holds them): its repr names them all; a true
    constant of a method, left as it is, is omitted."""
    assert (
        repr(build("estimator", "wls", n_joints=7, min_relative_std=1e-3))
        == "WeightedLeastSquares(min_relative_std=0.001, n_joints=7, near_rest='weighted', reweight_steps=2)"
    )

    class Hull(HyperParameters):
        def __init__(self, *, margin: float, dimension: int = 3) -> None:  # 3-D space: not a setting
            self.margin = margin
            self.dimension = dimension

    assert repr(Hull(margin=0.1)) == "Hull(margin=0.1)"
    assert repr(Hull(margin=0.1, dimension=2)) == "Hull(dimension=2, margin=0.1)"


def test_positional_varargs_and_objects_without_the_protocol_are_refused() -> None:
    class Loose(HyperParameters):
        def __init__(self, *weights: float) -> None:
            self.weights = weights

    with pytest.raises(TypeError, match="\\*args"):
        Loose(1.0).get_params()
    with pytest.raises(TypeError, match="get_params"):
        clone_estimator(object())


def test_bootstrap_resamples_the_instruments_with_the_rows(rng: np.random.Generator) -> None:
    """With the regressor itself as instruments, IV is OLS: each IV refit must equal the OLS refit
    on the same resampled rows, which holds only when the instruments follow the rows."""
    w = rng.normal(size=(600, 3))
    tau = w @ np.array([1.0, -2.0, 0.5]) + 0.3 * rng.normal(size=600)

    class Context:  # the one field IV reads, plus the resampling the bootstrap asks for
        def __init__(self, reference_regressor: np.ndarray) -> None:
            self.reference_regressor = reference_regressor

        def take_rows(self, rows: np.ndarray) -> Context:
            return Context(self.reference_regressor[rows])

    settings = dict(n_joints=2, block_samples=10, resamples=20, seed=4, show_progress=False)
    iv = block_bootstrap(build("estimator", "iv"), w, tau, context=Context(w), **settings)
    ols = block_bootstrap(build("estimator", "ols"), w, tau, **settings)
    np.testing.assert_allclose(iv.estimates, ols.estimates, rtol=1e-9, atol=1e-12)
    assert iv.std.max() > 0  # the refits do differ from one another
