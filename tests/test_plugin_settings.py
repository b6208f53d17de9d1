"""Every default in exactly one place: a plugin's YAML holds its settings, its signature none of their values.

For every option of the plugin groups (``conf/<group>/*.yaml``) and every plugin node nested elsewhere in
the config tree (the optimal motion's parameterisation, a task's tool motion): the node's keys are
exactly the target's parameters, less the runtime inputs listed below (each with why), and the target
gives no parameter a Python default. A value is then written once, a setting the YAML forgets fails
when the plugin is built, and a key the target does not take fails here (that estimators store the
YAML's values untouched for ``get_params``/``clone`` is tests/test_estimators_plugins.py's). Python
callers build a plugin from its YAML with :func:`lwrlab.pipeline.build.build`, checked at the end.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hydra.utils import get_object
from omegaconf import DictConfig, ListConfig, OmegaConf

from lwrlab.pipeline.build import build

CONF = Path(__file__).resolve().parents[1] / "conf"

PLUGIN_MODULES = {
    "classifier": "plugins.classifiers.",
    "controller": "plugins.controllers.",
    "criterion": "plugins.criteria.",
    "estimator": "plugins.estimators.",
    "friction": "plugins.friction.",
    "optimizer": "lwrlab.excitation.solver.",
    "robot": "plugins.robots.",
    "trajectory": "plugins.trajectories.",
}
"""Plugin group → where its targets live (the optimizer is a core solver)."""

RUNTIME_INPUTS: dict[str, dict[str, str]] = {
    # Every group's constructors take settings only; what a run hands a plugin goes to its methods.
    "classifier": {},  # the tool library arrives at fit(library), the identified φ at predict(φ, Σ)
    "controller": {},  # model, plant, path and force feedback arrive at law() and in the contact loop
    "criterion": {},  # the scaled base regressor arrives at value_and_gradient(W_b)
    "estimator": {},  # W, τ and the identification context arrive at fit(W, tau, context=...)
    "friction": {},  # drive speeds arrive at coulomb_shape(v), the logs' speed noise at candidates()
    "optimizer": {},  # the excitation problem arrives at solve(problem)
    "robot": {},  # a robot is built from its description alone
    "trajectory": {},  # the robot and the rate arrive at sample(robot, rate_hz)
}
"""Per plugin group, constructor parameters a job passes at run time instead of the YAML, with why."""

NESTED_RUNTIME_INPUTS: dict[tuple[str, str], dict[str, str]] = {
    ("trajectory/optimal", "parameterisation"): {
        "duration": "the optimal motion's own `duration`, passed when it builds the problem",
        "coefficients": "None: the bare parameterisation whose coefficients the optimiser finds",
    },
}
"""Per nested partial plugin node (file, key path), the parameters its owner passes, with why."""


def _options() -> list[tuple[str, str]]:
    return [(group, path.stem) for group in PLUGIN_MODULES for path in sorted((CONF / group).glob("*.yaml"))]


def _walk(node: Any, path: str = "") -> Iterator[tuple[str, DictConfig]]:
    """Every mapping node below ``node`` that names a ``_target_``, with its dotted key path."""
    if isinstance(node, DictConfig):
        if path and "_target_" in node:
            yield path, node
        for key in node:
            yield from _walk(node._get_node(key), f"{path}.{key}" if path else str(key))
    elif isinstance(node, ListConfig):
        for index in range(len(node)):
            yield from _walk(node._get_node(index), f"{path}[{index}]")


def _nested_plugin_nodes() -> list[tuple[str, str]]:
    """(file below conf/ without .yaml, key path) of every nested node targeting a plugin of these groups."""
    found = []
    for file in sorted(CONF.rglob("*.yaml")):
        for path, node in _walk(OmegaConf.load(file)):
            if str(node["_target_"]).startswith(tuple(PLUGIN_MODULES.values())):
                found.append((str(file.relative_to(CONF).with_suffix("")), path))
    return found


OPTIONS = _options()
NESTED = _nested_plugin_nodes()


def _group_of(target: str) -> str:
    return next(group for group, prefix in PLUGIN_MODULES.items() if target.startswith(prefix))


def _parameters(target: Callable[..., Any]) -> dict[str, inspect.Parameter]:
    """The named parameters of a class's constructor or a function (``**documentation`` and the like
    excluded: extra keys a robot description may carry to document itself)."""
    parameters = inspect.signature(target).parameters
    assert not any(p.kind is p.VAR_POSITIONAL for p in parameters.values()), f"{target}: *args"
    return {name: p for name, p in parameters.items() if p.kind is not p.VAR_KEYWORD}


def _check(node: DictConfig, runtime: dict[str, str], where: str) -> None:
    target = get_object(str(node["_target_"]))
    parameters = _parameters(target)
    defaulted = sorted(name for name, p in parameters.items() if p.default is not inspect.Parameter.empty)
    assert defaulted == [], (
        f"{where}: {node['_target_']} gives {defaulted} Python defaults: the YAML holds them"
    )
    settings = {str(key) for key in node if not str(key).startswith("_")}
    assert not settings & set(runtime), f"{where}: {sorted(settings & set(runtime))} arrive at run time"
    assert settings | set(runtime) == set(parameters), (
        f"{where}: the YAML sets {sorted(settings)} (+ run time {sorted(runtime)}), "
        f"{node['_target_']} takes {sorted(parameters)}"
    )


def test_every_plugin_group_has_its_options() -> None:
    by_group = {group: {option for g, option in OPTIONS if g == group} for group in PLUGIN_MODULES}
    assert by_group["estimator"] >= {"ols", "wls", "irls", "iv", "sdp"}
    assert by_group["trajectory"] >= {"optimal", "bspline", "fourier", "multisine", "multisine_validation"}
    assert by_group["robot"] >= {"kuka_lwr4", "panda", "urdf", "mdh_file", "identified"}
    assert by_group["controller"] >= {"force_pi", "position"}
    assert all(by_group.values()), f"a plugin group without options: {by_group}"
    assert ("trajectory/optimal", "parameterisation") in NESTED


@pytest.mark.parametrize(("group", "option"), OPTIONS, ids=[f"{g}/{o}" for g, o in OPTIONS])
def test_the_yaml_gives_every_setting_and_the_target_no_default(group: str, option: str) -> None:
    node = OmegaConf.load(CONF / group / f"{option}.yaml")
    assert str(node["_target_"]).startswith(PLUGIN_MODULES[group]), f"{group}/{option}: {node['_target_']}"
    _check(node, RUNTIME_INPUTS[group], f"{group}/{option}")


@pytest.mark.parametrize(("file", "path"), NESTED, ids=[f"{f}:{p}" for f, p in NESTED])
def test_nested_plugin_nodes_give_every_setting(file: str, path: str) -> None:
    node = OmegaConf.select(OmegaConf.load(CONF / f"{file}.yaml"), path)
    runtime = NESTED_RUNTIME_INPUTS.get((file, path), RUNTIME_INPUTS[_group_of(str(node["_target_"]))])
    _check(node, runtime, f"{file}:{path}")


def test_runtime_inputs_name_real_parameters() -> None:
    """The exemptions above point at parameters that exist (a renamed one fails here, not silently)."""
    for (file, path), runtime in NESTED_RUNTIME_INPUTS.items():
        node = OmegaConf.select(OmegaConf.load(CONF / f"{file}.yaml"), path)
        assert set(runtime) <= set(_parameters(get_object(str(node["_target_"])))), (file, path)


def test_a_plugin_without_its_yaml_values_is_refused() -> None:
    """No silent fallback: leaving a setting out is an error naming it."""
    from plugins.estimators.wls import WeightedLeastSquares

    with pytest.raises(TypeError, match="reweight_steps"):
        WeightedLeastSquares(n_joints=None, min_relative_std=1e-6)  # type: ignore[call-arg]


# --- build(): the shipped YAML as a one-liner for Python callers --------------------------------------


def test_build_takes_the_yaml_values_and_changes_only_the_overrides() -> None:
    wls = build("estimator", "wls", n_joints=7)
    assert (wls.n_joints, wls.min_relative_std, wls.reweight_steps) == (7, 1e-6, 2)
    assert build("estimator", "wls").n_joints is None  # the YAML's value, untouched by the call before


def test_build_resolves_interpolations_to_the_shipped_defaults_and_merges_nested_overrides() -> None:
    from plugins.criteria.cond import ConditionNumber

    source = build(
        "trajectory", "optimal", constraints={"torque": False}, criterion=ConditionNumber(sharpness=4.0)
    )
    assert source.constraints.torque is False and source.constraints.min_link_gap == 2  # the rest kept
    assert source.criterion.sharpness == 4.0  # a built object passes through
    assert build("trajectory", "optimal").criterion.name == "logdet"  # ${criterion}: config.yaml's default
    assert build("trajectory", "multisine").seed == 0  # ${seed}


def test_build_names_what_it_does_not_know() -> None:
    with pytest.raises(ValueError, match=r"no setting \['rcond_typo'\].*\['rcond'\]"):
        build("estimator", "ols", rcond_typo=1.0)
    with pytest.raises(ValueError, match="no option 'ridge'"):
        build("estimator", "ridge")
