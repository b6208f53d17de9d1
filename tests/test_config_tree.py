"""Every option of every config group and every experiment preset composes, passes the settings checks,
leaves no value missing and builds: each ``_target_`` node is instantiated with the runtime inputs the
pipeline gives it (the robot to a plant, the tool library to a classifier, …), nothing is run.

The schemas (lwrlab/config/) type the settings; this suite is what says that the YAML files, the
schemas, the rules of lwrlab/pipeline/config_checks.py and the plugins' signatures agree.
"""

from __future__ import annotations

import inspect
import textwrap
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from composing import CONF, compose_config
from hydra.errors import ConfigCompositionException, InstantiationException
from hydra.utils import instantiate
from omegaconf import DictConfig, ListConfig, OmegaConf
from test_classifiers import library  # noqa: F401  (the tool library fixture the classifiers fit)
from test_identified_robot import _identified_run

from lwrlab.io.urdf_export import export_urdf
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_checks import violations
from lwrlab.signal.processing import process
from lwrlab.tools.library import ToolLibrary

GROUPS = (
    "classifier",
    "controller",
    "criterion",
    "estimator",
    "robot",
    "plant",
    "statistics",
    "tracking",
    "trajectory",
    "measurement",
    "optimizer",
    "tool",
    "task",
)
OPTIONS = [(group, path.stem) for group in GROUPS for path in sorted((CONF / group).glob("*.yaml"))]
PRESETS = sorted(path.stem for path in (CONF / "experiment").glob("*.yaml"))


@dataclass(frozen=True)
class Inputs:
    """What a job hands the objects it builds: the robot (the LWR4 of conf/robot/), the tool library."""

    robot: RobotModel
    library: ToolLibrary
    files: Path
    """Folder holding the files options name: a URDF, an identified model's run folder."""


@pytest.fixture(scope="module")
def inputs(lwr4: RobotModel, library: ToolLibrary, tmp_path_factory: pytest.TempPathFactory) -> Inputs:  # noqa: F811
    files = tmp_path_factory.mktemp("config_tree")
    export_urdf(lwr4, files / "lwr4.urdf")
    _identified_run(lwr4, files / "identified_run")
    return Inputs(lwr4, library, files)


def required_overrides(group: str, option: str, inputs: Inputs) -> list[str]:
    """What a user must give with this option (its ``???`` values): files, logs."""
    needs = {
        ("robot", "mdh_file"): [f"robot.path={CONF / 'robot' / 'kuka_lwr4.yaml'}"],
        ("robot", "urdf"): [f"robot.path={inputs.files / 'lwr4.urdf'}"],
        ("robot", "identified"): [f"robot.source={inputs.files / 'identified_run'}"],
        ("plant", "log"): ["data.paths=[identification.csv]"],  # read when measured, not when built
    }
    return needs.get((group, option), [])


# --- how the pipeline builds each node, and what the built object must offer --------------------------


def _has(*attributes: str) -> Callable[[Any], bool]:
    return lambda built: all(hasattr(built, a) for a in attributes)


BUILDERS: dict[str, tuple[Callable[[Any, Inputs], Any], Callable[[Any], bool]]] = {
    "robot": (lambda node, inputs: instantiate(node), lambda built: isinstance(built, RobotModel)),
    "trajectory": (lambda node, inputs: instantiate(node), _has("sample")),
    "validation": (lambda node, inputs: instantiate(node), _has("sample")),
    "criterion": (lambda node, inputs: instantiate(node), _has("value_and_gradient", "name")),
    "optimizer": (lambda node, inputs: instantiate(node), _has("solve")),
    "plant": (lambda node, inputs: instantiate(node)(robot=inputs.robot), _has("measure", "truth")),
    "estimator": (lambda node, inputs: instantiate(node), _has("fit", "predict", "get_params")),
    "friction": (lambda node, inputs: instantiate(node), _has("coulomb_shape", "candidates", "settings")),
    "classifier": (lambda node, inputs: instantiate(node).fit(inputs.library), _has("predict", "distances")),
    "tool": (lambda node, inputs: instantiate(node), _has("parameters", "geometry")),
    "controller": (lambda node, inputs: instantiate(node), _has("uses_force_feedback", "desired_force")),
    "task": (lambda node, inputs: instantiate(node), callable),  # a stage (cfg, output_dir) -> metrics
    "callbacks": (lambda node, inputs: instantiate(node), _has("on_job_start", "on_job_end")),
}
"""Per node: how the pipeline builds it (``instantiate(cfg.plant)(robot=robot)``, …), what it must offer."""


def target_paths(node: Any, path: str = "") -> Iterator[str]:
    """Dotted paths of every node with a ``_target_`` below ``node`` (interpolations not followed)."""
    if isinstance(node, DictConfig):
        if "_target_" in node:
            yield path
        for key in node:
            yield from target_paths(node._get_node(key), f"{path}.{key}" if path else str(key))
    elif isinstance(node, ListConfig):
        for index in range(len(node)):
            yield from target_paths(node._get_node(index), f"{path}.{index}")


def missing_values(node: Any, path: str = "") -> Iterator[str]:
    """Dotted paths of ``???`` values below ``node`` (interpolations not resolved: a painting setting
    copying ``plant.torque_noise_std`` need not resolve when the plant reads logs)."""
    if isinstance(node, DictConfig | ListConfig):
        keys = list(node) if isinstance(node, DictConfig) else range(len(node))
        for key in keys:
            yield from missing_values(node._get_node(key), f"{path}.{key}" if path else str(key))
    elif node is not None and node._is_missing():
        yield path


def build_every_target(cfg: DictConfig, inputs: Inputs, keys: list[str]) -> list[str]:
    """Build the nodes at ``keys`` as the pipeline does; return the ``_target_`` paths they covered."""
    covered = []
    for key in keys:
        node = OmegaConf.select(cfg, key)
        if node is None:
            continue
        kind = key.rsplit(".", 1)[0].rsplit(".", 1)[-1] if key.startswith("hydra.") else key
        build, offers = BUILDERS[kind]
        built = build(node, inputs)
        assert offers(built), f"{key}: {type(built).__name__} lacks what the pipeline uses"
        covered += [f"{key}.{inner}" if inner else key for inner in target_paths(node)]
    return covered


def top_level_targets(cfg: DictConfig) -> list[str]:
    """Keys of the top-level nodes with a ``_target_``, and of the tracking callbacks."""
    keys = [
        str(k)
        for k in cfg
        if k != "hydra" and isinstance(cfg._get_node(k), DictConfig) and "_target_" in cfg[k]
    ]
    callbacks = OmegaConf.select(cfg, "hydra.callbacks", default=None) or {}
    return keys + [f"hydra.callbacks.{name}" for name in callbacks]


def check_composed(cfg: DictConfig, inputs: Inputs, keys: list[str]) -> None:
    """The settings checks pass, no value is missing, and every ``_target_`` in ``keys`` builds."""
    job = OmegaConf.masked_copy(cfg, [k for k in cfg if k != "hydra"])  # what the job receives
    assert violations(job) == []
    assert list(missing_values(job)) == [], "a schema key without a value in the YAML"
    covered = build_every_target(cfg, inputs, keys)
    for key in keys:
        assert {path for path in target_paths(OmegaConf.select(cfg, key), key)} <= set(covered)


def keys_of_option(group: str, option: str, cfg: DictConfig) -> list[str]:
    """The nodes an option of ``group`` fills: its own, or for tracking the callbacks it adds."""
    if group == "tracking":
        return [k for k in top_level_targets(cfg) if k.startswith("hydra.callbacks.")]
    node = cfg[group]
    return [group] if isinstance(node, DictConfig) and "_target_" in node else []


@pytest.mark.parametrize(("group", "option"), OPTIONS, ids=[f"{g}={o}" for g, o in OPTIONS])
def test_every_option_composes_passes_the_checks_and_builds(group: str, option: str, inputs: Inputs) -> None:
    cfg = compose_config(f"{group}={option}", *required_overrides(group, option, inputs), hydra_node=True)
    keys = keys_of_option(group, option, cfg)
    check_composed(cfg, inputs, keys)
    if group in ("robot", "trajectory", "plant", "estimator", "classifier", "criterion", "optimizer", "tool"):
        assert keys == [group], f"{group}={option} has no _target_: nothing would build it"


@pytest.mark.parametrize("preset", PRESETS)
def test_every_preset_composes_passes_the_checks_and_builds(preset: str, inputs: Inputs) -> None:
    cfg = compose_config(f"experiment={preset}", hydra_node=True)
    check_composed(cfg, inputs, top_level_targets(cfg))


def test_the_processing_settings_are_the_keywords_of_process() -> None:
    keywords = {name for name, p in inspect.signature(process).parameters.items() if p.kind is p.KEYWORD_ONLY}
    settings = set(compose_config().measurement.processing)
    assert settings <= keywords, f"not keywords of process(): {settings - keywords}"


def test_schemas_are_not_choices_so_runs_log_the_options_chosen() -> None:
    """The tracking logs Hydra's runtime choices as the job's options (``statistics=covariance``)."""
    cfg = compose_config("plant=log", "data.paths=[a.csv]", "statistics=covariance", hydra_node=True)
    choices = OmegaConf.to_container(cfg.hydra.runtime.choices)
    assert isinstance(choices, dict)
    assert not [group for group in choices if "schema" in str(group)]
    assert choices["statistics"] == "covariance" and choices["tracking"] == "sqlite"


def test_the_suite_walks_every_group_and_preset() -> None:
    assert {group for group, _ in OPTIONS} == set(GROUPS)
    assert len(OPTIONS) > 50 and len(PRESETS) >= 9


# --- the suite can fail: broken options in a user's search path are caught --------------------------


def _user_option(tmp_path: Path, group: str, name: str, text: str) -> str:
    folder = tmp_path / "conf" / group
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.yaml").write_text(textwrap.dedent(text))
    return f"hydra.searchpath=[file://{tmp_path / 'conf'}]"


def test_an_option_whose_target_does_not_build_is_caught(tmp_path: Path, inputs: Inputs) -> None:
    searchpath = _user_option(
        tmp_path, "estimator", "ridge", "_target_: plugins.estimators.ols.OrdinaryLeastSquares\nalpha: 1.0\n"
    )
    cfg = compose_config(searchpath, "estimator=ridge", hydra_node=True)
    with pytest.raises(InstantiationException, match="alpha"):
        check_composed(cfg, inputs, keys_of_option("estimator", "ridge", cfg))


def test_a_copied_option_with_a_misspelt_or_mistyped_setting_fails_when_composed(tmp_path: Path) -> None:
    simulated = (CONF / "plant" / "simulated.yaml").read_text()
    searchpath = _user_option(
        tmp_path, "plant", "noisy", simulated.replace("torque_noise_std:", "torque_noise:")
    )
    with pytest.raises(ConfigCompositionException) as error:
        compose_config(searchpath, "plant=noisy")
    assert "plant.torque_noise" in str(error.value) and "SimulatedPlantSettings" in str(error.value)
    searchpath = _user_option(tmp_path, "plant", "typo", simulated.replace("substeps: 4", "substeps: four"))
    with pytest.raises(ConfigCompositionException) as error:
        compose_config(searchpath, "plant=typo")
    assert "plant.substeps" in str(error.value)


def test_a_user_option_without_a_schema_stays_open(tmp_path: Path, inputs: Inputs) -> None:
    """A new plugin's YAML (README "Adding a plugin") needs no schema: its keys are its own."""
    searchpath = _user_option(
        tmp_path,
        "plant",
        "mine",
        "_target_: plugins.plants.simulated.SimulatedPlant\n_partial_: true\nseed: 3\n",
    )
    cfg = compose_config(searchpath, "plant=mine", hydra_node=True)
    check_composed(cfg, inputs, ["plant"])
    assert OmegaConf.get_type(cfg.plant) is dict
