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

Side effects (files) only in :func:`run_painting`; the other functions return values.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.control.contact_loop import ContactRun, PaintingController, simulate_contact
from lwrlab.control.filters import FirstOrderLowPass
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.planning.coverage import painted_fraction
from lwrlab.planning.painting_path import PaintingPathParameters
from lwrlab.planning.path_optimisation import PathProblem, PathSolution, WallBounds, optimise_path
from lwrlab.plants.mujoco_contact import ContactTool, MujocoContactPlant, Wall
from lwrlab.tools.model import Tool

log = logging.getLogger(__name__)

COMPARISONS = (("estimated", "measured"), ("estimated", "desired"), ("measured", "desired"))
"""Table IV's rows: the first signal against the second."""


def tcp_transform(tool: Tool) -> np.ndarray:
    """(4, 4) the tool centre point (middle of the contact line) in the flange frame, flange axes."""
    pose = np.eye(4)
    pose[:3, 3] = tool.contact_point
    return pose


def force_errors(first: np.ndarray, second: np.ndarray) -> tuple[float, float]:
    """RMS (N) of ``first − second`` and NRMS (%): RMS over the mean magnitude of ``second``.

    The paper's NRMS (Table IV: 2.9 N ↔ 9.8 %, 0.2 N ↔ 0.7 %) is this ratio with ``second`` ≈ 30 N.
    """
    rms = float(np.sqrt(np.mean((first - second) ** 2)))
    return rms, float(100.0 * rms / np.abs(np.mean(second)))


@dataclass
class RollerPlan:
    """What the painting of one roller starts from."""

    tool: Tool
    """The true roller (the plant carries it)."""
    recognised: Tool
    """The library tool recognition returned (its width and contact point plan the path)."""
    identified_parameters: np.ndarray
    """(10,) identified flange-frame parameters of the roller (eq. 7)."""
    path: PathSolution
    optimisation_s: float


def normal_force_table(run: ContactRun, desired_force: float, cutoff_hz: float) -> dict[str, np.ndarray]:
    """Desired, estimated and measured normal force (N) over the painting samples.

    The wall sensor's reading passes through the same causal low-pass as the estimate (``cutoff_hz``),
    so both are compared at the bandwidth the controller uses; the stiff contact's kHz ringing,
    which neither the estimate nor a force loop can follow, is left out of both.
    """
    measured = FirstOrderLowPass(cutoff_hz, float(run.t[1] - run.t[0])).apply(
        run.measured_force[:, 0], initial=0.0
    )
    mask = run.painting
    return {
        "t": run.t[mask],
        "estimated": run.estimated_wrench[mask, 0],
        "measured": measured[mask],
        "desired": np.full(int(mask.sum()), desired_force),
    }


def reference_poses(
    plan: RollerPlan,
    wall: Wall,
    rate_hz: float,
    approach_s: float,
    duration_scale: float,
    max_duration: float | None,
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4, 4) tool poses at the control rate: ``approach_s`` at the start point, then the path.

    ``duration_scale`` shortens the path in time (same geometry), ``max_duration`` cuts the run
    (s); both are for quick checks only. Returns the poses and the painting mask.
    """
    parameters = plan.path.parameters
    if duration_scale != 1.0:
        parameters = PaintingPathParameters(
            **{**parameters.__dict__, "duration": parameters.duration * duration_scale}
        )
    from lwrlab.planning.painting_path import sample_path

    path = sample_path(parameters, wall.x, rate_hz)
    poses = path.poses()
    approach = np.repeat(poses[:1], int(round(approach_s * rate_hz)), axis=0)
    reference = np.concatenate([approach, poses])
    painting = np.concatenate([np.zeros(approach.shape[0], bool), np.ones(poses.shape[0], bool)])
    if max_duration is not None:
        n = int(round(max_duration * rate_hz))
        reference, painting = reference[:n], painting[:n]
    return reference, painting


def paint(
    plan: RollerPlan,
    truth: RobotModel,
    controller_model: RobotModel,
    controller: PaintingController,
    wall: Wall,
    contact: Mapping[str, Any],
    estimator_settings: Mapping[str, Any],
    seed: int,
    rate_hz: float = 1000.0,
) -> ContactRun:
    """One painting run in MuJoCo: true robot + roller on the plant side, ``controller_model`` in the controller."""
    period = 1.0 / rate_hz
    plant = MujocoContactPlant(
        truth,
        ContactTool(
            plan.tool.parameters,
            plan.tool.contact_point,
            plan.tool.contact_axis,
            plan.tool.width,
            float(contact.get("contact_radius", 0.025)),
        ),
        wall,
        control_period=period,
        substeps=int(contact.get("substeps", 2)),
        torque_noise_std=contact["torque_noise_std"],
        encoder_noise_std=float(contact["encoder_noise_std"]),
        force_noise_std=float(contact.get("force_noise_std", 0.0)),
        friction=float(contact.get("friction", 0.1)),
        contact_time_constant=float(contact.get("contact_time_constant", 0.02)),
        seed=seed,
    )
    tcp = tcp_transform(plan.recognised)
    setup = ControlSetup(
        controller_model,
        SwivelIK(controller_model),
        tcp,
        plan.path.parameters.swivel,
        plan.path.branch,
        period,
    )
    estimator = ExternalForceEstimator(controller_model, tcp, period, **estimator_settings)
    reference, painting = reference_poses(
        plan,
        wall,
        rate_hz,
        float(contact["approach_s"]),
        float(contact.get("duration_scale", 1.0)),
        contact.get("max_duration"),
    )
    start = reference[0].copy()
    start[0, 3] += float(contact["standoff"])  # start off the wall; the force loop brings the roller on it
    steps = tqdm(
        range(reference.shape[0]), desc="contact simulation", unit="step", leave=False, mininterval=2.0
    )
    return simulate_contact(
        plant, controller, estimator, setup, reference, painting, start=start, progress=steps
    )


def _wall(wall: Mapping[str, float]) -> Wall:
    return Wall(**{k: float(v) for k, v in wall.items()})


def run_painting(
    cfg: Any,
    output_dir: Path,
    tools: Sequence[str] = ("large_roller", "small_roller"),
    n_steps: Mapping[str, int] | None = None,
    models: Sequence[str] = ("identified", "cad"),
    feedbacks: Sequence[str] = ("estimate", "sensor"),
    wall: Mapping[str, float] | None = None,
    path: Mapping[str, Any] | None = None,
    contact: Mapping[str, Any] | None = None,
    estimator: Mapping[str, Any] | None = None,
    tool_motion: Any = None,
    comparison_controller: Any = None,
    identification: Any = None,
) -> dict[str, float]:
    """Task ``painting``: Table IV, Fig. 12 and Fig. 13 for each roller (keyword arguments: conf/task/painting.yaml).

    ``identification``: the :class:`~lwrlab.pipeline.identification.IdentificationReport` of this
    config's robot and plant when an earlier stage made it (the plant is drawn again from the same
    seed, so its truth is the same); None identifies the robot here.

    Writes ``table4_force.csv`` with columns ``roller, model, feedback, comparison, rms, nrms``
    (model: ``identified`` | ``cad`` | ``position`` (the comparison position controller, identified
    model); feedback: ``estimate`` | ``sensor`` | ``none``; comparison: ``estimated/measured``,
    ``estimated/desired``, ``measured/desired`` of the normal force F_x over the painting path; rms in
    N, nrms in % of the second signal's mean magnitude), ``painting_paths.csv`` (per roller: the
    eq. (12) solution x = [T_C, φ, Z_u, Z_l, Y_0, ΔY], N_r, branch, cost terms, painted area (m²),
    recognised tool and w_L, optimisation time), ``painting_runs.csv`` (per run: coverage of the
    planned area from the contact trace, its worst interior column (2 mm cells, 1 cm from the
    sides left out) and worst row, path tracking RMS in the wall
    plane (m), mean normal forces, simulation time), ``contact_<roller>_<model>_<feedback>.npz``
    (the run at 100 Hz: reference, commanded and actual positions, wrenches, joints), figures ``fig12_<roller>.png`` and ``fig13_<roller>.png``, and
    ``summary.md``.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    from lwrlab.figures.painting import normal_force, path_on_wall
    from lwrlab.pipeline.identification import identify_configured
    from lwrlab.pipeline.tool_library import load_library
    from lwrlab.pipeline.tools import ToolBench, identify_tool

    output_dir.mkdir(parents=True, exist_ok=True)
    path = dict(path or {})
    contact = dict(contact or {})
    estimator_settings = dict(estimator or {})
    n_steps = dict(n_steps or {})
    the_wall = _wall(wall or {})
    seed = int(cfg.seed)
    rate = float(cfg.measurement.rate_hz)
    processing = OmegaConf.to_container(cfg.measurement.processing, resolve=True)

    # 1. identification of the robot, then of each roller and its recognition
    timing: dict[str, float] = {}  # identification_s: only when this stage identifies (else the caller's)
    if identification is None:
        started = time.perf_counter()
        identification = identify_configured(cfg)
        timing["identification_s"] = time.perf_counter() - started
    report = identification
    robot = report.robot
    plant = instantiate(cfg.plant, tool=None, show_progress=False)(robot=robot)
    identified_robot = robot.with_parameters(report.identified.standard_values)
    truth = plant.truth.robot
    log.info("identified %s: cross-validation mean RMS %.3f N·m", robot.name, report.metrics["rms_mean"])
    library = load_library(None)
    classifier = instantiate(cfg.classifier).fit(library)
    bench = ToolBench.for_robot(robot, processing)
    unloaded = bench.data(plant, report.motion)
    # Hydra builds nested `_target_` configs of the task before calling it: these arrive as objects
    loaded_motion = tool_motion.sample(robot, rate) if tool_motion is not None else report.motion

    plans: dict[str, RollerPlan] = {}
    for name in tools:
        tool = library[name]
        estimate = identify_tool(bench, unloaded, bench.data(plant.with_tool(tool), loaded_motion))
        recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
        recognised = library[recognition.tool]
        log.info("%s: recognised as %s (w_L = %.3f m)", name, recognised.name, recognised.width)
        problem = PathProblem(
            attach_payload(identified_robot, estimate.phi_flange),
            SwivelIK(identified_robot),
            tcp_transform(recognised),
            WallBounds(the_wall.x, *the_wall.y_bounds, *the_wall.z_bounds),
            roller_width=recognised.width,
            n_steps=int(n_steps.get(name, 2)),
            branch=Branch(*path.get("branch", (1, -1, -1))),
            rate_hz=float(path.get("rate_hz", 100.0)),
            search_rate_hz=float(path.get("search_rate_hz", 10.0)),
            duration_bounds=tuple(path.get("duration_bounds", (10.0, 120.0))),
            min_stroke=float(path.get("min_stroke", 0.1)),
            singularity_margin=float(path.get("singularity_margin", 0.1)),
            stripe_overlap=float(path.get("stripe_overlap", 0.0)),
        )
        started = time.perf_counter()
        solution = optimise_path(
            problem, starting_swivels=tuple(path.get("starting_swivels", (-1.6, -0.8))), progress=True
        )
        plans[name] = RollerPlan(
            tool, recognised, estimate.phi_flange, solution, time.perf_counter() - started
        )

    # 2. painting runs
    # a controller without force feedback (controller=position) runs once per model
    cases = [
        (model, feedback)
        for model in models
        for feedback in (feedbacks if "feedback" in cfg.controller else ["none"])
    ]
    desired = float(
        np.asarray(OmegaConf.to_container(cfg.controller, resolve=True).get("desired_force", [-30.0, 0, 0]))[
            0
        ]
    )
    cutoff = float(estimator_settings.get("wrench_cutoff_hz", 20.0))
    rows, run_rows, metrics = [], [], {**timing, "identification_rms_mean": report.metrics["rms_mean"]}
    for name, plan in plans.items():
        models_for = {
            "identified": attach_payload(identified_robot, plan.identified_parameters),
            "cad": attach_payload(robot, plan.recognised.parameters),
        }
        runs: dict[tuple[str, str], ContactRun] = {}
        jobs = [
            (m, f, instantiate(cfg.controller, **({"feedback": f} if f != "none" else {}))) for m, f in cases
        ]
        if comparison_controller is not None:
            jobs.append(("position", "none", comparison_controller))
        for model, feedback, controller in jobs:
            started = time.perf_counter()
            run = paint(
                plan,
                truth,
                models_for["identified" if model == "position" else model],
                controller,
                the_wall,
                contact,
                estimator_settings,
                seed,
            )
            seconds = time.perf_counter() - started
            runs[(model, feedback)] = run
            forces = normal_force_table(run, desired, cutoff)
            for first, second in COMPARISONS:
                rms, nrms = force_errors(forces[first], forces[second])
                rows.append(
                    {
                        "roller": name,
                        "model": model,
                        "feedback": feedback,
                        "comparison": f"{first}/{second}",
                        "rms": rms,
                        "nrms": nrms,
                    }
                )
            in_contact = run.painting & (run.measured_force[:, 0] < -1.0)
            p = plan.path.parameters
            width = plan.recognised.width
            coverage, painted = painted_fraction(
                run.actual[:, 1],
                run.actual[:, 2],
                in_contact,
                plan.tool.width,
                (p.y_start - width / 2, p.y_end + width / 2, p.z_lower, p.z_upper),
            )
            tracking = float(
                np.sqrt(
                    np.mean(
                        np.sum((run.actual[run.painting, 1:] - run.reference[run.painting, 1:]) ** 2, axis=1)
                    )
                )
            )
            run_rows.append(
                {
                    "roller": name,
                    "model": model,
                    "feedback": feedback,
                    "coverage": coverage,
                    # a gap between two stripes would leave an interior column (a vertical band)
                    # unpainted; the outer 1 cm on each side follows the path's lateral tracking error
                    "worst_interior_column_coverage": float(painted.mean(axis=0)[5:-5].min()),
                    "worst_row_coverage": float(painted.mean(axis=1).min()),
                    "tracking_rms_m": tracking,
                    "mean_measured_N": float(forces["measured"].mean()),
                    "mean_estimated_N": float(forces["estimated"].mean()),
                    "painting_s": float(run.painting.sum() * (run.t[1] - run.t[0])),
                    "simulation_s": seconds,
                }
            )
            metrics[f"coverage_{name}_{model}_{feedback}"] = coverage
            decimated = slice(None, None, 10)  # 100 Hz: the figures' resolution, a few MB per run
            np.savez_compressed(
                output_dir / f"contact_{name}_{model}_{feedback}.npz",
                t=run.t[decimated],
                reference=run.reference[decimated],
                commanded=run.commanded[decimated],
                actual=run.actual[decimated],
                estimated_wrench=run.estimated_wrench[decimated],
                measured_force=run.measured_force[decimated],
                q=run.q[decimated],
                q_desired=run.q_desired[decimated],
                tau=run.tau[decimated],
                painting=run.painting[decimated],
            )
        # figures like the paper's (large roller in Fig. 13; here every roller)
        main = runs.get(("identified", "estimate")) or next(iter(runs.values()))
        path_on_wall(
            main.reference[main.painting],
            main.actual[main.painting],
            (*the_wall.y_bounds, *the_wall.z_bounds),
            output_dir / f"fig12_{name}.png",
            f"{name}: desired vs actual path",
        )
        panels = {
            f"{model} model, {feedback} feedback": {
                k: v
                for k, v in normal_force_table(run, desired, cutoff).items()
                if k in ("estimated", "measured")
            }
            for (model, feedback), run in runs.items()
            if model != "position"
        }
        t_painting = main.t[main.painting]
        normal_force(
            t_painting - t_painting[0],
            panels,
            desired,
            output_dir / f"fig13_{name}.png",
            f"{name}: normal force on the wall",
        )

    table = pd.DataFrame(rows)
    run_table = pd.DataFrame(run_rows)
    plans_table = pd.DataFrame(
        [
            {
                "roller": name,
                "recognised": plan.recognised.name,
                "roller_width_m": plan.recognised.width,
                **dict(
                    zip(
                        ("T_C", "phi", "Z_u", "Z_l", "Y_0", "dY"),
                        plan.path.parameters.vector().tolist(),
                        strict=True,
                    )
                ),
                "N_r": plan.path.parameters.n_steps,
                "branch": tuple(plan.path.branch),
                **{f"cost_{k}": v for k, v in plan.path.cost_terms.items()},
                "painted_area_m2": plan.path.painted_area,
                "active_constraints": "; ".join(plan.path.active),
                "optimisation_s": plan.optimisation_s,
            }
            for name, plan in plans.items()
        ]
    )
    table.to_csv(output_dir / "table4_force.csv", index=False)
    run_table.to_csv(output_dir / "painting_runs.csv", index=False)
    plans_table.to_csv(output_dir / "painting_paths.csv", index=False)
    for row in rows:
        key = f"{row['roller']}_{row['model']}_{row['feedback']}_{row['comparison'].replace('/', '_vs_')}"
        metrics[f"rms_{key}"] = row["rms"]
    for name, plan in plans.items():
        metrics[f"duration_s_{name}"] = plan.path.parameters.duration
        metrics[f"painted_area_m2_{name}"] = plan.path.painted_area
    text = format_painting(table, plans_table, run_table)
    (output_dir / "summary.md").write_text(text + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return {k: float(v) for k, v in metrics.items()}


def format_painting(table: pd.DataFrame, plans: pd.DataFrame, runs: pd.DataFrame) -> str:
    """Table IV (RMS and NRMS per roller, model and feedback), the optimised paths and the runs, as Markdown."""
    wide = table.pivot_table(
        index=["model", "feedback", "comparison"], columns="roller", values=["rms", "nrms"], sort=False
    )
    wide.columns = [f"{roller} {stat}" for stat, roller in wide.columns]
    wide = wide[sorted(wide.columns, key=lambda c: (c.split()[0], c.split()[1] != "rms"))]
    return "\n".join(
        [
            "## Table IV: normal external force (RMS in N, NRMS in %)",
            "",
            wide.reset_index().to_markdown(index=False, floatfmt=".3g"),
            "",
            "## Optimised painting paths (eq. 12)",
            "",
            plans.drop(columns=["active_constraints"]).to_markdown(index=False, floatfmt=".4g"),
            "",
            "## Painting runs",
            "",
            runs.to_markdown(index=False, floatfmt=".4g"),
        ]
    )
