"""Painting stage (§IV–VI.B, Table IV): identify, recognise the roller, plan, paint with force control.

For every roller the chain of Fig. 1 runs on the simulated LWR4:

1. the robot is identified on the simulated plant (:func:`lwrlab.pipeline.identification.identify`,
   once for all rollers); the roller's 10 parameters by eq. (7) from an unloaded and a loaded motion
   and the roller recognised in the tool library, which gives its width w_L and contact point;
2. the painting path is optimised (eq. 12) with the identified robot + roller;
3. the path is painted in MuJoCo (the plant's *true* robot and roller, a wall with a force sensor,
   1 kHz) by the ``controller`` plugin (force PI around joint PD + gravity) whose model — gravity
   compensation and external force estimation (eq. 14) — is the identified one or the CAD one, with
   the estimated or the sensed force fed back; and by the comparison position controller;
4. the normal forces are compared (Table IV) and the painted coverage measured from the contact trace.

:func:`paint` is pure computation on configured objects and returns a :class:`PaintingReport`;
:mod:`lwrlab.pipeline.painting.report` writes it to disk. :func:`run_painting`, the task, builds the
objects from the config, paints and writes.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.control.contact_loop import PaintingController
from lwrlab.errors import ConfigError
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings
from lwrlab.pipeline.identification import IdentificationReport
from lwrlab.pipeline.painting.runs import (
    COMPARISONS,
    RollerPlan,
    ScoredRun,
    score_run,
    simulate_painting,
    tcp_transform,
)
from lwrlab.pipeline.tools.bench import ToolBench, ToolPlant, identify_tool
from lwrlab.planning.path_optimisation import optimise_path
from lwrlab.planning.path_problem import PathProblem, WallBounds
from lwrlab.plants.mujoco_contact import Wall
from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.model import Tool
from lwrlab.tools.recognition import ToolClassifier
from lwrlab.trajectory.core import MotionSource, Trajectory

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class PaintingSettings:
    """The painting task's settings (conf/task/painting.yaml, the one place of their values)."""

    tools: tuple[str, ...]
    """Rollers to paint with (names in the tool library)."""
    n_steps: Mapping[str, int]
    """N_r per roller: horizontal steps of the zig-zag."""
    models: tuple[str, ...]
    """The controller's model: ``identified`` and/or ``cad``."""
    feedbacks: tuple[str, ...]
    """Force fed back (``estimate`` | ``sensor``) by a controller with force feedback."""
    wall: Wall
    path: Mapping[str, Any]
    """Eq. (12): rate_hz, search_rate_hz, torque_stride, duration_bounds, min_stroke, singularity_margin,
    stripe_overlap, branch, starting_swivels."""
    contact: Mapping[str, Any]
    """The MuJoCo plant and the run's timing (see :func:`simulate_painting`)."""
    estimator: Mapping[str, Any]
    """Keyword arguments of :class:`~lwrlab.control.force_estimation.ExternalForceEstimator`."""


@dataclass
class PaintingReport:
    """Everything a painting stage produced, in memory."""

    plans: dict[str, RollerPlan]
    """Per roller: recognition, identified parameters and optimised path."""
    runs: list[ScoredRun]
    """Every painting run (roller × model × feedback, then the comparison controller), scored."""
    wall: Wall
    desired_force: float | None
    """F_d along the wall normal (N) of the controller, None when it has no force target."""
    timings: dict[str, float]
    """Stage wall times (s) not held by a plan or a run: ``identification_s`` when identified here."""
    metrics: dict[str, float]

    @property
    def force_errors(self) -> pd.DataFrame:
        """Table IV: roller, model, feedback, comparison, rms (N), rms_over_mean_pct (%)."""
        return pd.DataFrame([row for run in self.runs for row in run.force_errors])

    @property
    def run_summary(self) -> pd.DataFrame:
        """Per run: coverage, worst column and row, tracking RMS, mean forces, times."""
        return pd.DataFrame([run.summary for run in self.runs])

    @property
    def path_summary(self) -> pd.DataFrame:
        """Per roller: the eq. (12) solution, its cost terms, painted area and optimisation time."""
        return pd.DataFrame([plan.summary(name) for name, plan in self.plans.items()])


def path_problem(
    robot: RobotModel,
    tool_parameters: np.ndarray,
    recognised: Tool,
    wall: Wall,
    n_steps: int,
    path: Mapping[str, Any],
) -> PathProblem:
    """Eq. (12) for ``robot`` carrying a roller of inertia ``tool_parameters`` (10, flange frame) and of
    the geometry of ``recognised`` (w_L, contact point), painting ``wall`` in ``n_steps`` steps (N_r).

    ``path``: the painting task's ``path`` settings (conf/task/painting.yaml; ``starting_swivels`` is
    :func:`optimise_path`'s).
    """
    return PathProblem(
        attach_payload(robot, tool_parameters),
        SwivelIK(robot),
        tcp_transform(recognised),
        WallBounds(wall.x, *wall.y_bounds, *wall.z_bounds),
        roller_width=recognised.width,
        n_steps=n_steps,
        branch=Branch(*path["branch"]),
        rate_hz=float(path["rate_hz"]),
        search_rate_hz=float(path["search_rate_hz"]),
        torque_stride=int(path["torque_stride"]),
        duration_bounds=tuple(path["duration_bounds"]),
        min_stroke=float(path["min_stroke"]),
        singularity_margin=float(path["singularity_margin"]),
        stripe_overlap=float(path["stripe_overlap"]),
    )


def plan_roller(
    tool: Tool,
    estimate_parameters: np.ndarray,
    recognised: Tool,
    identified_robot: RobotModel,
    settings: PaintingSettings,
) -> RollerPlan:
    """The painting path (eq. 12) of ``tool``, recognised as ``recognised``, on ``identified_robot``."""
    if tool.name not in settings.n_steps:
        raise ConfigError(f"task.n_steps has no entry for roller {tool.name!r}: {dict(settings.n_steps)}")
    n_steps = int(settings.n_steps[tool.name])
    problem = path_problem(
        identified_robot, estimate_parameters, recognised, settings.wall, n_steps, settings.path
    )
    started = time.perf_counter()
    starts = tuple(settings.path["starting_swivels"])
    solution = optimise_path(problem, starting_swivels=starts, progress=True)
    return RollerPlan(tool, recognised, estimate_parameters, solution, time.perf_counter() - started)


def plan_rollers(
    settings: PaintingSettings,
    *,
    identification: IdentificationReport,
    plant: ToolPlant,
    library: ToolLibrary,
    classifier: ToolClassifier,
    bench: ToolBench,
    loaded_motion: Trajectory | None,
) -> dict[str, RollerPlan]:
    """Identify and recognise each roller of ``settings.tools`` and optimise its painting path.

    ``loaded_motion`` carries each roller for its identification (None: the identification's
    exciting motion). The plans :func:`paint` paints and ``task=live_painting`` paints over ROS 2.
    """
    robot = identification.robot
    identified_robot = robot.with_parameters(identification.identified.standard_values)
    if identification.motion is None:
        raise ConfigError("the painting stage needs a simulated plant (the identification played no motion)")
    unloaded = bench.data(plant, identification.motion)
    loaded = loaded_motion if loaded_motion is not None else identification.motion
    plans: dict[str, RollerPlan] = {}
    for name in settings.tools:
        tool = library[name]
        estimate = identify_tool(bench, unloaded, bench.data(plant.with_tool(tool), loaded))
        recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
        if not recognition.known:  # the path still needs a width: the nearest tool's, said aloud
            warnings.warn(f"{name}: {recognition.describe()}; painting with its geometry", stacklevel=1)
        recognised = library[recognition.nearest]
        log.info("%s: recognised as %s (w_L = %.3f m)", name, recognition.tool, recognised.width)
        plans[name] = plan_roller(tool, estimate.phi_flange, recognised, identified_robot, settings)
    return plans


def paint(
    settings: PaintingSettings,
    *,
    identification: IdentificationReport,
    plant: ToolPlant,
    library: ToolLibrary,
    classifier: ToolClassifier,
    bench: ToolBench,
    loaded_motion: Trajectory | None,
    make_controller: Callable[..., PaintingController],
    comparison_controller: PaintingController | None,
    seed: int,
    timings: Mapping[str, float],
) -> PaintingReport:
    """Identify and recognise each roller, plan its path, paint it with every controller case and score it.

    ``loaded_motion`` carries each roller for its identification (None: the identification's
    exciting motion). ``make_controller(**overrides)`` builds the ``controller`` plugin; when it declares
    ``uses_force_feedback`` it runs once per ``settings.feedbacks`` (``feedback=…``), else once per
    model (feedback ``none``). ``comparison_controller`` (model ``position``, identified model) runs
    after them when given. ``timings`` are the caller's stage times (``identification_s``).
    """
    plans = plan_rollers(
        settings,
        identification=identification,
        plant=plant,
        library=library,
        classifier=classifier,
        bench=bench,
        loaded_motion=loaded_motion,
    )
    robot = identification.robot
    identified_robot = robot.with_parameters(identification.identified.standard_values)
    main = make_controller()
    force_feedback = bool(main.uses_force_feedback)
    desired = None if main.desired_force is None else float(main.desired_force[0])  # along the wall normal
    cases = [(m, f) for m in settings.models for f in (settings.feedbacks if force_feedback else ("none",))]
    cutoff = float(settings.estimator["wrench_cutoff_hz"])

    runs: list[ScoredRun] = []
    for name, plan in plans.items():
        models_for = {
            "identified": attach_payload(identified_robot, plan.identified_parameters),
            "cad": attach_payload(robot, plan.recognised.parameters),
        }
        jobs = [(m, f, make_controller(**({"feedback": f} if force_feedback else {}))) for m, f in cases]
        if comparison_controller is not None:
            jobs.append(("position", "none", comparison_controller))
        started = time.perf_counter()
        contact_runs = simulate_painting(
            plan,
            plant.truth.robot,
            [(models_for["identified" if model == "position" else model], c) for model, _, c in jobs],
            settings.wall,
            settings.contact,
            settings.estimator,
            seed,
        )
        share = (time.perf_counter() - started) / len(jobs)  # stepped together: each run its share
        for (model, feedback, _), run in zip(jobs, contact_runs, strict=True):
            runs.append(score_run(name, model, feedback, plan, run, desired, cutoff, share))
    metrics = {**timings, "identification_rms_mean": identification.metrics["rms_mean"]}
    metrics |= {f"coverage_{scored.key}": scored.summary["coverage"] for scored in runs}
    for scored in runs:
        for row in scored.force_errors:
            metrics[f"rms_{scored.key}_{row['comparison'].replace('/', '_vs_')}"] = row["rms"]
    for name, plan in plans.items():
        metrics[f"duration_s_{name}"] = plan.path.parameters.duration
        metrics[f"painted_area_m2_{name}"] = plan.path.painted_area
    return PaintingReport(plans, runs, settings.wall, desired, dict(timings), metrics)


def configured_objects(
    cfg: Any, identification: IdentificationReport, tool_motion: MotionSource | None
) -> dict[str, Any]:
    """The objects ``cfg`` configures for :func:`plan_rollers` (plant, library, classifier, bench and
    the loaded motion), on ``identification``'s robot."""
    from hydra.utils import instantiate

    from lwrlab.pipeline.tools.library import load_library

    robot = identification.robot
    library = load_library(None)
    return {
        "identification": identification,
        "plant": instantiate(cfg.plant, tool=None, show_progress=False)(robot=robot),
        "library": library,
        "classifier": instantiate(cfg.classifier).fit(library),
        "bench": ToolBench.for_robot(robot, processing_settings(cfg)),
        "loaded_motion": None
        if tool_motion is None
        else tool_motion.sample(robot, float(cfg.measurement.rate_hz)),
    }


def identify_for_painting(cfg: Any, timings: dict[str, float]) -> IdentificationReport:
    """The robot identified on ``cfg``'s plant (its wall time in ``timings["identification_s"]``)."""
    from lwrlab.pipeline.identification import identify_configured

    started = time.perf_counter()
    identification = identify_configured(cfg)
    timings["identification_s"] = time.perf_counter() - started
    log.info(
        "identified %s: cross-validation mean RMS %.3f N·m",
        identification.robot.name,
        identification.metrics["rms_mean"],
    )
    return identification


def paint_configured(
    cfg: Any,
    settings: PaintingSettings,
    tool_motion: MotionSource | None,
    comparison_controller: PaintingController | None,
    identification: IdentificationReport | None,
) -> PaintingReport:
    """:func:`paint` with the objects ``cfg`` configures (plant, classifier, controller, processing).

    ``tool_motion``: the motion carrying each roller for its identification (None: the
    identification's exciting motion). ``identification``: an earlier stage's report of this
    config's robot and plant (the plant is drawn again from the same seed, so its truth is the
    same); None identifies the robot here.
    """
    from functools import partial

    from hydra.utils import instantiate

    timings: dict[str, float] = {}
    if identification is None:
        identification = identify_for_painting(cfg, timings)
    return paint(
        settings,
        **configured_objects(cfg, identification, tool_motion),
        make_controller=partial(instantiate, cfg.controller),
        comparison_controller=comparison_controller,
        seed=int(cfg.seed),
        timings=timings,
    )


def painting_settings(
    *,
    tools: Sequence[str],
    n_steps: Mapping[str, int],
    models: Sequence[str],
    feedbacks: Sequence[str],
    wall: Mapping[str, float],
    path: Mapping[str, Any],
    contact: Mapping[str, Any],
    estimator: Mapping[str, Any],
) -> PaintingSettings:
    """:class:`PaintingSettings` from the painting task's YAML values (conf/task/painting.yaml)."""
    return PaintingSettings(
        tools=tuple(tools),
        n_steps=dict(n_steps),
        models=tuple(models),
        feedbacks=tuple(feedbacks),
        wall=Wall(**{key: float(value) for key, value in wall.items()}),
        path=dict(path),
        contact=dict(contact),
        estimator=dict(estimator),
    )


def run_painting(
    cfg: Any,
    output_dir: Path,
    *,
    tools: Sequence[str],
    n_steps: Mapping[str, int],
    models: Sequence[str],
    feedbacks: Sequence[str],
    wall: Mapping[str, float],
    path: Mapping[str, Any],
    contact: Mapping[str, Any],
    estimator: Mapping[str, Any],
    tool_motion: MotionSource | None,
    comparison_controller: PaintingController | None,
    identification: IdentificationReport | None = None,
) -> dict[str, float]:
    """Task ``painting``: Table IV, Fig. 12 and Fig. 13 per roller (keyword arguments: its YAML).

    Hydra builds the nested ``_target_`` settings (``tool_motion``, ``comparison_controller``) before
    the call. ``identification``: see :func:`paint_configured`. Paints (:func:`paint`), writes the
    report (:func:`lwrlab.pipeline.painting.report.write_painting`, which lists the files), prints
    its summary and returns its metrics.
    """
    from lwrlab.pipeline.painting.report import format_painting, write_painting

    settings = painting_settings(
        tools=tools,
        n_steps=n_steps,
        models=models,
        feedbacks=feedbacks,
        wall=wall,
        path=path,
        contact=contact,
        estimator=estimator,
    )
    report = paint_configured(cfg, settings, tool_motion, comparison_controller, identification)
    write_painting(report, output_dir)
    print(format_painting(report))
    return {key: float(value) for key, value in report.metrics.items()}


__all__ = [
    "COMPARISONS",
    "PaintingReport",
    "PaintingSettings",
    "configured_objects",
    "identify_for_painting",
    "paint",
    "paint_configured",
    "painting_settings",
    "path_problem",
    "plan_rollers",
    "run_painting",
]
