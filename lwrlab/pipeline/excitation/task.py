"""Task ``excitation`` (Katsumata et al. §III): optimise one exciting motion and write it.

The three exciting-motion tasks (config group ``task``), each ``f(cfg, output_dir) -> metrics``, read
the excitation settings from ``cfg.trajectory``, which must be ``trajectory=optimal``
(:func:`require_optimal`):

* ``excitation`` (:func:`run_excitation`, here): optimise the motion, write it
  (``exciting_motion.yaml`` + 1 kHz ``exciting_motion.csv``), its report and figure;
* ``duration_study`` (:mod:`lwrlab.pipeline.studies.duration_study`, preset
  ``experiment=paper_fig5_duration``): the optimal cost of each criterion for each duration T_F,
  ``fig5_duration.csv`` and the knee rule;
* ``criteria_comparison`` (:mod:`lwrlab.pipeline.studies.criteria_comparison`, preset
  ``experiment=paper_fig6_criteria``): each criterion's optimum → simulated measurement →
  identification → cross-validation, over seeds, ``fig6_criteria.csv``.
"""

from __future__ import annotations

import json
import logging
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.problem import require_motion_limits
from lwrlab.figures.excitation import motion_figure
from lwrlab.identification.identifiability import DEFAULT_POOR_COND
from lwrlab.io.artifacts import save_trajectory_csv
from lwrlab.io.exciting_motion import save_motion_description
from lwrlab.io.target_motions import read_target_motions
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra
from lwrlab.pipeline.excitation.known import known_information
from lwrlab.pipeline.excitation.uncertainty_report import next_motion_report, plant_noise_density

log = logging.getLogger(__name__)


def require_optimal(cfg: Any, criteria: Mapping[str, Criterion] | None = None) -> None:
    """Fail fast, before any long work, on a configuration these tasks cannot run."""
    target = str(cfg.trajectory.get("_target_", ""))
    if not target.endswith("OptimalExcitingMotion"):
        raise ValueError(
            "this task optimises exciting motions: it needs trajectory=optimal, got "
            f"trajectory._target_={target!r}"
        )
    if criteria is not None and not criteria:
        raise ValueError(
            "no criteria to compare: task.criteria is empty (add some with "
            "+criterion@task.criteria.<name>=<option>)"
        )


def optimal_source(cfg: Any, **overrides: Any) -> Any:
    """``cfg.trajectory`` instantiated (it must be the ``optimal`` plugin), with keyword overrides."""
    from hydra.utils import instantiate

    require_optimal(cfg)
    return instantiate(cfg.trajectory, **overrides)


@dense_algebra()
def regressor_condition(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, base: BaseParameters | None = None
) -> float:
    """cond(W_b) of a motion after scaling the columns to unit norm (as the estimators report it)."""
    from lwrlab.dynamics.regressor import regressor
    from lwrlab.identification.core import column_scaled_condition_number

    base = compute_base_parameters(robot) if base is None else base
    return column_scaled_condition_number(base.base_regressor(regressor(robot, q, dq, ddq)))


def _command_line() -> str:
    """The command that ran this job (to regenerate its artifacts)."""
    try:
        from hydra.core.hydra_config import HydraConfig

        return "lwrlab " + " ".join(shlex.quote(o) for o in HydraConfig.get().overrides.task)
    except ValueError:  # not inside a Hydra job (tests)
        return "lwrlab task=excitation"


PREVIEW_APPROACHES = 6
"""Closest approaches drawn on the preview besides the violated ones."""
GOAL_RATES_HZ = (10.0, 20.0, 50.0, 100.0)
"""Rates tried for the FollowJointTrajectory goal, the lowest whose quintic interpolation stays within
GOAL_DEVIATION of the motion (a goal passed on the command line must stay under the shell's 128 KiB)."""
GOAL_DEVIATION = 1e-6
"""Largest deviation (rad) of the controller's interpolation from the motion, for the goal's rate."""


def goal_rate(t: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> float:
    """The lowest of :data:`GOAL_RATES_HZ` at which quintic interpolation reproduces the motion within
    :data:`GOAL_DEVIATION` (a quintic B-spline sampled at its knots is reproduced exactly)."""
    from lwrlab.io.ros2_trajectory import quintic_interpolation

    period = float(np.median(np.diff(t)))
    for rate in GOAL_RATES_HZ:
        step = max(1, round(1.0 / (rate * period)))
        keep = np.unique(np.append(np.arange(0, len(t), step), len(t) - 1))
        error = np.abs(quintic_interpolation(t[keep], q[keep], dq[keep], ddq[keep], t) - q).max()
        if error <= GOAL_DEVIATION:
            return rate
    return GOAL_RATES_HZ[-1]


def _motion_figures(
    scene: Any, trajectory: Any, check: Any, output_dir: Path, prefix: str, title: str, settings: Any
) -> Path:
    """The preview of the robot at the motion's key poses, closest approaches marked."""
    from lwrlab.excitation.collision_scene import posed_meshes
    from lwrlab.figures.motion_preview import BodyMesh, Snapshot, key_times, motion_preview_figure

    found = list(check.collisions.approaches) if check.collisions is not None else []
    # the violated approaches and the nearest few: a picture of every pair would hide the robot
    approaches = [a for a in found if a.violated] + [a for a in found if not a.violated][:PREVIEW_APPROACHES]
    snapshots = []
    for t, label in key_times(trajectory.t, approaches):
        k = int(np.argmin(np.abs(trajectory.t - t)))
        meshes = tuple(BodyMesh(n, v, f, w) for n, v, f, w in posed_meshes(scene, trajectory.q[k]))
        snapshots.append(Snapshot(float(trajectory.t[k]), meshes, label))
    mounting = settings.mounting_surface(scene.robot)
    height = None if mounting is None else float(mounting.get("height", 0.0))
    return motion_preview_figure(snapshots, approaches, output_dir / f"{prefix}_preview.png", title, height)


def _check_table(check: Any, verify_rate_hz: float) -> list[str]:
    lines = [
        f"## Check at {verify_rate_hz:g} Hz against the true limits and the robot's geometry",
        "",
        "| constraint | worst slack | unit | where | t [s] |",
        "|---|---|---|---|---|",
        *[
            f"| {r.family} | {r.worst_slack:.4g} | {r.unit} | {r.where} | {r.time_s:.3f} |"
            for r in check.reports
        ],
    ]
    collisions = check.collisions
    if collisions is not None:
        kind = "the robot's collision geometry (coal)" if collisions.exact else "its collision spheres"
        lines += [
            "",
            f"### Closest approaches ({kind}; {collisions.pairs_checked} pairs, "
            f"{collisions.exact_queries} exact queries, {collisions.seconds:.2f} s)",
            "",
            "| kind | bodies | distance [mm] | clearance [mm] | t [s] |",
            "|---|---|---|---|---|",
            *[
                f"| {a.kind} | {a.body_a}–{a.body_b} | {1000 * a.distance:.1f} | {1000 * a.clearance:.0f} "
                f"| {a.t:.3f} |"
                for a in collisions.approaches[:12]
            ],
        ]
        if collisions.contacts:
            lines += ["", "**Contacts:**", "", *[f"- {line}" for line in collisions.describe().split("\n  ")]]
    return lines


def run_excitation(
    cfg: Any,
    output_dir: Path,
    verify_rate_hz: float = 1000.0,
    known_logs: Sequence[str] | None = None,
    known_model: str | None = None,
    targets: Sequence[Any] | None = None,
) -> dict[str, float]:
    """Task ``excitation``: optimise the exciting motion of ``cfg.robot``, check it, and write it.

    With ``known_logs`` (read by the ``plant=log`` reader) and/or ``known_model`` (a path or MLflow
    model URI), the motion is designed for what they leave unknown: the criterion scores the known
    information and the motion's together (:mod:`lwrlab.pipeline.excitation.known`). The report says
    the expected std of each base parameter before and after the motion (``parameter_uncertainty.csv``),
    which stay poorly known, and the expected torque std along the ``targets`` (where the model will be
    used: :mod:`lwrlab.io.target_motions`; ``criterion=target_variance`` aims the motion at them).

    The motion is checked at ``verify_rate_hz`` against every limit and against the robot's own
    collision geometry and world (:func:`lwrlab.excitation.solver.check_motion_at`). Accepted, it is
    written as ``exciting_motion.yaml`` (parameterisation and coefficients, loadable with
    ``trajectory.from_file=…``), ``exciting_motion.csv`` (t, q, q̇, q̈ at ``verify_rate_hz``),
    ``exciting_motion.parquet``, a ROS 2 bag of one ``trajectory_msgs/JointTrajectory``
    (``exciting_motion_bag/``) and a ``FollowJointTrajectory`` goal (``exciting_motion_goal.yaml``).
    Rejected, the same files are named ``rejected_exciting_motion.*`` (no ROS 2 export) and the run
    fails with :class:`~lwrlab.excitation.solver.RejectedMotionError` naming the constraint, the
    bodies, the time and the amount. Both write ``excitation_report.md``, ``exciting_motion.png``,
    ``<name>_preview.png`` (the robot at key poses, closest approaches marked) and ``metrics.json``.
    """
    from hydra.utils import instantiate

    from lwrlab.excitation.solver import RejectedMotionError, check_motion_at
    from lwrlab.io.artifacts import save_trajectory

    robot: RobotModel = instantiate(cfg.robot)
    require_motion_limits(robot)  # before any work, in one line
    source = optimal_source(cfg)
    base = compute_base_parameters(robot)
    known = known_information(cfg, robot, base, known_logs, known_model)
    target_motions = read_target_motions(list(targets or []), robot.n_joints, robot.joint_names, robot.drive)
    world = source.constraints.describe_world(robot)
    log.info("%s keeps clear of %s", robot.name, world)
    motion, result, problem = source.optimise(robot, base, known)
    q, dq, ddq = (b @ result.coefficients for b in problem.bases)
    check = check_motion_at(robot, motion, source.constraints, verify_rate_hz)
    trajectory = motion.sample(robot, verify_rate_hz)
    torque = robot.inverse_dynamics(trajectory.q, trajectory.dq, trajectory.ddq)
    output_dir.mkdir(parents=True, exist_ok=True)
    accepted = check.passed
    prefix = "exciting_motion" if accepted else "rejected_exciting_motion"
    collisions = check.collisions
    provenance = {
        "robot": robot.name,
        "criterion": source.criterion.name,
        "cost": result.cost,
        "cond_W_b": regressor_condition(robot, q, dq, ddq, problem.base),
        "worst_slack_at_verify_rate": {r.family: f"{r.worst_slack:.4g} {r.unit}" for r in check.reports},
        "verify_rate_hz": verify_rate_hz,
        "collision_model": "none"
        if collisions is None
        else ("exact geometry" if collisions.exact else "collision spheres"),
        "accepted": accepted,
        "optimisation_seconds": round(result.seconds, 2),
        "known": [] if known is None else list(known.sources),
        "command": _command_line(),
    }
    if known is None and provenance["cond_W_b"] > DEFAULT_POOR_COND:  # conditioned: alone it needn't
        log.warning(
            "the exciting motion of %s excites its base parameters poorly: cond(W_b) = %.4g (> %g, the "
            "identifiability report's threshold); try more starts (optimizer.n_starts), a longer motion "
            "(trajectory.duration) or looser constraints",
            robot.name,
            provenance["cond_W_b"],
            DEFAULT_POOR_COND,
        )
    save_motion_description(motion.to_dict(), output_dir / f"{prefix}.yaml", provenance)
    save_trajectory_csv(trajectory, output_dir / f"{prefix}.csv")
    save_trajectory(trajectory, output_dir / f"{prefix}.parquet")
    verdict = (
        "**Accepted**: every limit and every distance holds at every sample."
        if accepted
        else "**Rejected**: not a motion to run (files named `rejected_exciting_motion.*`).\n\n  "
        + check.describe()
    )
    report_lines = [
        f"# Optimal exciting motion: {robot.name}, {source.criterion.name}, "
        f"{motion.duration:g} s {motion.kind}",
        "",
        verdict,
        "",
        f"World: {world}.",
        "",
        "## Optimisation (constraints on the optimisation grid, with the limit margin)",
        "",
        result.summary(),
        "",
        *_check_table(check, verify_rate_hz),
        "",
        f"cond(W_b) (unit-norm columns, {problem.rate_hz:g} Hz grid): {provenance['cond_W_b']:.4g}",
    ]
    density, noise_source = plant_noise_density(cfg)
    next_motion = next_motion_report(
        problem, result.coefficients, known, density, noise_source, target_motions
    )
    output_dir.mkdir(parents=True, exist_ok=True)
    next_motion.write(output_dir, robot.name)
    still_poor = next_motion.parameters.poorly_known(after=True)
    if still_poor:
        log.warning(
            "%d base parameter(s) of %s stay poorly known after this motion (%s): design another for them "
            "(task.known_logs / task.known_model), or a longer one (trajectory.duration)",
            len(still_poor),
            robot.name,
            ", ".join(still_poor[:8]),
        )
    report_lines += ["", *next_motion.lines()]
    scene = problem.constraint_set.scene
    if scene.notes:
        report_lines += ["", "Pairs not checked:", "", *[f"- {note}" for note in scene.notes]]
    if accepted:
        from lwrlab.io.ros2_trajectory import write_follow_joint_trajectory_goal, write_joint_trajectory_bag

        arrays = (trajectory.t, trajectory.q, trajectory.dq, trajectory.ddq)
        # a controller knows the joints by the URDF's names (a modified-DH robot's own are joint1…)
        geometry = problem.constraint_set.scene.geometry
        joint_names = list(geometry.joint_names if geometry is not None else robot.joint_names)
        bag = output_dir / "exciting_motion_bag"
        if bag.exists():
            import shutil

            shutil.rmtree(bag)
        write_joint_trajectory_bag(bag, joint_names, *arrays)
        write_follow_joint_trajectory_goal(
            output_dir / "exciting_motion_goal.yaml",
            joint_names,
            *arrays,
            rate_hz=goal_rate(*arrays),
        )
        report_lines += [
            "",
            "## On the robot",
            "",
            "Start pose (bring the arm there at rest first), rad: "
            + ", ".join(f"{n} {v:.4f}" for n, v in zip(joint_names, trajectory.q[0], strict=True)),
            "",
            "ROS 2: `exciting_motion_bag/` (one `trajectory_msgs/msg/JointTrajectory`) and "
            "`exciting_motion_goal.yaml` (a `control_msgs/action/FollowJointTrajectory` goal; its header "
            "says how to send it).",
        ]
    report = "\n".join(report_lines)
    (output_dir / "excitation_report.md").write_text(report + "\n")
    title = f"Optimal exciting motion ({source.criterion.name}, {robot.name})"
    motion_figure(
        trajectory.t,
        trajectory.q,
        trajectory.dq,
        trajectory.ddq,
        torque,
        output_dir / "exciting_motion.png",
        title,
    )
    _motion_figures(
        scene,
        trajectory,
        check,
        output_dir,
        prefix,
        title + ("" if accepted else ": REJECTED"),
        source.constraints,
    )
    print(report)
    closest_self = collisions.closest("self") if collisions is not None else None
    closest_world = collisions.closest("world") if collisions is not None else None
    metrics = {
        "cost": result.cost,
        "cond_W_b": float(provenance["cond_W_b"]),
        "optimisation_seconds": result.seconds,
        "iterations": float(result.iterations),
        "violated_families": float(sum(r.violated for r in check.reports)),
        "accepted": float(accepted),
        **{f"worst_slack_{r.family}": r.worst_slack for r in check.reports},
        **next_motion.metrics(),
    }
    if collisions is not None:
        metrics["collision_check_seconds"] = collisions.seconds
        if closest_self is not None:
            metrics["closest_self_m"] = closest_self.distance
        if closest_world is not None:
            metrics["closest_world_m"] = closest_world.distance
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    if not accepted:
        raise RejectedMotionError(
            f"the optimised exciting motion of {robot.name} fails its check at {verify_rate_hz:g} Hz and was "
            f"not written as a motion to run (kept as {output_dir / prefix}.*): {check.describe()}"
        )
    return metrics
