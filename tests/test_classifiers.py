"""Conformance of every classifier plugin (conf/classifier/*.yaml) and the geometry interpolation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from lwrlab.pipeline.build import build
from lwrlab.pipeline.tools.library import load_library
from lwrlab.tools.recognition import UNKNOWN_TOOL, interpolate_geometry, noise_distance, recognise

CLASSIFIERS = sorted(Path(__file__).resolve().parents[1].joinpath("conf", "classifier").glob("*.yaml"))


@pytest.fixture(scope="module")
def library():
    return load_library()


def _covariance(library) -> np.ndarray:
    """A covariance shaped like an identification's: 1 % of each parameter's spread over the library."""
    return np.diag((0.01 * library.parameters.std(axis=0) + 1e-9) ** 2)


@pytest.mark.parametrize("path", CLASSIFIERS, ids=lambda p: p.stem)
def test_every_classifier_recognises_every_library_tool(path: Path, library) -> None:
    classifier = instantiate(OmegaConf.load(path))
    assert classifier.fit(library) is classifier
    covariance = _covariance(library)
    rng = np.random.default_rng(0)
    for tool in library:
        exact = classifier.predict(tool.parameters, covariance)
        assert exact.tool == tool.name and exact.confidence == pytest.approx(1.0)
        assert exact.known and exact.noise_distance == 0.0
        assert exact.geometry == tool.geometry and exact.kind == tool.kind
        noisy = tool.parameters + rng.multivariate_normal(np.zeros(10), covariance)
        recognition = classifier.predict(noisy, covariance)
        assert recognition.tool == tool.name, f"{path.stem} took {tool.name} for {recognition.tool}"
        assert 0.0 < recognition.confidence <= 1.0
        assert set(recognition.distances) == set(library.names)


@pytest.mark.parametrize("path", CLASSIFIERS, ids=lambda p: p.stem)
def test_every_classifier_calls_a_tool_outside_its_library_unknown(path: Path, library) -> None:
    """Open set: a tool held out of the library is unknown, not the nearest one's name."""
    covariance = _covariance(library)
    for tool in library:
        classifier = instantiate(OmegaConf.load(path)).fit(library.without(tool.name))
        assert np.isfinite(classifier.unknown_distance)  # every shipped classifier makes the test
        recognition = classifier.predict(tool.parameters, covariance)
        assert recognition.tool == UNKNOWN_TOOL and not recognition.known, f"{path.stem}: {tool.name}"
        assert recognition.nearest in library.names and recognition.nearest != tool.name
        assert recognition.noise_distance > recognition.unknown_distance
        assert recognition.distance == min(recognition.distances.values())
        assert "nearest " + recognition.nearest in recognition.describe()
    # the same tool back in the library, identified with noise: known again
    classifier = instantiate(OmegaConf.load(path)).fit(library)
    rng = np.random.default_rng(1)
    noisy = library.tools[0].parameters + rng.multivariate_normal(np.zeros(10), covariance)
    recognition = classifier.predict(noisy, covariance)
    assert recognition.known and 0.0 < recognition.noise_distance < recognition.unknown_distance


def test_the_noise_distance_is_in_standard_deviations(rng: np.random.Generator) -> None:
    factor = rng.normal(size=(10, 10))
    covariance = factor @ factor.T + np.eye(10)
    step = rng.normal(size=10)
    step *= 3.0 / np.sqrt(step @ np.linalg.solve(covariance, step))  # 3 σ along a random direction
    assert noise_distance(step, np.zeros(10), covariance, ridge=0.0) == pytest.approx(3.0)


@pytest.mark.parametrize("path", CLASSIFIERS, ids=lambda p: p.stem)
def test_classifiers_refuse_bad_input(path: Path, library) -> None:
    classifier = instantiate(OmegaConf.load(path))
    with pytest.raises(RuntimeError, match="not fitted"):
        classifier.predict(library.tools[0].parameters, _covariance(library))
    classifier.fit(library)
    with pytest.raises(ValueError, match="10 inertial parameters"):
        classifier.predict(np.ones(9), _covariance(library))


def test_mahalanobis_needs_a_covariance(library) -> None:
    with pytest.raises(ValueError, match="covariance"):
        build("classifier", "mahalanobis").fit(library).predict(library.tools[0].parameters)


def test_pca_lookup_is_the_papers_projection(library) -> None:
    pca = build("classifier", "pca_lookup", n_components=4).fit(library)
    u, _, _ = np.linalg.svd(library.parameters.T, full_matrices=False)  # Φ̄ = U·S·Vᵀ, 10 × N_T
    np.testing.assert_allclose(
        np.abs(pca.transform(library.parameters)), np.abs(library.parameters @ u[:, :4]), atol=1e-15
    )
    assert pca.explained_ > 0.999
    with pytest.raises(ValueError, match="scaling"):
        build("classifier", "pca_lookup", scaling="minmax").fit(library)


def test_recognition_confidence_is_one_minus_the_distance_ratio(library) -> None:
    distances = np.arange(1.0, len(library) + 1.0)
    recognition = recognise(library, distances)
    assert recognition.tool == library.names[0]
    assert recognition.confidence == pytest.approx(0.5)


def test_geometry_interpolation(rng: np.random.Generator) -> None:
    features = rng.normal(size=(8, 3))
    geometry = features @ rng.normal(size=(3, 2)) + np.array([0.3, 0.1])  # an affine relation
    query = rng.normal(size=3)
    expected = (
        query @ np.linalg.lstsq(np.column_stack([features, np.ones(8)]), geometry, rcond=None)[0][:3]
        + np.linalg.lstsq(np.column_stack([features, np.ones(8)]), geometry, rcond=None)[0][3]
    )
    np.testing.assert_allclose(
        interpolate_geometry(features, geometry, query, "linear", neighbours=3, ridge=0.0),
        expected,
        atol=1e-10,
    )
    exact = interpolate_geometry(features, geometry, features[2], "idw", neighbours=3)
    np.testing.assert_array_equal(exact, geometry[2])
    blended = interpolate_geometry(features, geometry, query, "idw", neighbours=3)
    assert np.all(blended >= geometry.min(axis=0)) and np.all(blended <= geometry.max(axis=0))
    with pytest.raises(ValueError, match="linear"):
        interpolate_geometry(features, geometry, query, "spline", neighbours=3)
