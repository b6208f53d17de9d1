"""Exciting-motion stages (Katsumata et al. §III): optimise one motion, the duration study, the criteria comparison.

Three tasks (config group ``task``), each ``f(cfg, output_dir) -> metrics``; they read the excitation
settings from ``cfg.trajectory``, which must be ``trajectory=optimal``:

* ``excitation`` (:func:`run_excitation`): optimise the motion, write it (``exciting_motion.yaml`` +
  1 kHz ``exciting_motion.csv``), its report and figure;
* ``duration_study`` (:func:`run_duration_study`, preset ``experiment=paper_fig5_duration``): the
  optimal cost of each criterion for each duration T_F, ``fig5_duration.csv`` and the knee rule;
* ``criteria_comparison`` (:func:`run_criteria_comparison`, preset ``experiment=paper_fig6_criteria``):
  each criterion's optimum → simulated measurement → identification → cross-validation, over seeds,
  ``fig6_criteria.csv``.
"""

from __future__ import annotations

import json
import logging
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.solver import ExcitationResult, InfeasibleExcitationError, verify_motion
from lwrlab.figures.excitation import criteria_figure, duration_figure, motion_figure
from lwrlab.io.artifacts import save_trajectory_csv
from lwrlab.io.exciting_motion import save_motion_description
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra

log = logging.getLogger(__name__)


def _require_optimal(cfg: Any, criteria: Mapping[str, Criterion] | None = None) -> None:
    """Fail fast, before any long work, on a configuration these tasks cannot run."""
    target = str(cfg.trajectory.get("_target_", ""))
    if not target.endswith("OptimalExcitingMotion"):
        raise ValueError(
            f"this task optimises exciting motions: it needs trajectory=optimal, got trajectory._target_={target!r}"
        )
    if criteria is not None and not criteria:
        raise ValueError(
            "no criteria to compare: task.criteria is empty (add some with +criterion@task.criteria.<name>=<option>)"
        )


def _optimal_source(cfg: Any, **overrides: Any) -> Any:
    """``cfg.trajectory`` instantiated (it must be the ``optimal`` plugin), with keyword overrides."""
    from hydra.utils import instantiate

    _require_optimal(cfg)
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


def run_excitation(cfg: Any, output_dir: Path, verify_rate_hz: float = 1000.0) -> dict[str, float]:
    """Task ``excitation``: optimise the exciting motion of ``cfg.robot`` and write it.

    Writes ``exciting_motion.yaml`` (parameterisation and coefficients, loadable with
    ``trajectory.from_file=…``), ``exciting_motion.csv`` (t, q, q̇, q̈ at ``verify_rate_hz``),
    ``excitation_report.md`` (criterion, worst slack per constraint family on the optimisation grid and
    at ``verify_rate_hz``), ``exciting_motion.png`` and ``metrics.json``.
    """
    from hydra.utils import instantiate

    robot: RobotModel = instantiate(cfg.robot)
    source = _optimal_source(cfg)
    motion, result, problem = source.optimise(robot)
    checks = verify_motion(robot, motion, source.constraints, verify_rate_hz)
    trajectory = motion.sample(robot, verify_rate_hz)
    torque = robot.inverse_dynamics(trajectory.q, trajectory.dq, trajectory.ddq)
    output_dir.mkdir(parents=True, exist_ok=True)
    provenance = {
        "robot": robot.name,
        "criterion": source.criterion.name,
        "cost": result.cost,
        "cond_W_b": regressor_condition(
            robot, *(b @ result.coefficients for b in problem.bases), problem.base
        ),
        "worst_slack_at_verify_rate": {r.family: f"{r.worst_slack:.4g} {r.unit}" for r in checks},
        "verify_rate_hz": verify_rate_hz,
        "optimisation_seconds": round(result.seconds, 2),
        "command": _command_line(),
    }
    save_motion_description(motion.to_dict(), output_dir / "exciting_motion.yaml", provenance)
    save_trajectory_csv(trajectory, output_dir / "exciting_motion.csv")
    report = "\n".join(
        [
            f"# Optimal exciting motion: {robot.name}, {source.criterion.name}, {motion.duration:g} s {motion.kind}",
            "",
            "## Optimisation (constraints on the optimisation grid, with the limit margin)",
            "",
            result.summary(),
            "",
            f"## Check at {verify_rate_hz:g} Hz against the true limits (no margin, exact Coulomb sign)",
            "",
            "| constraint | worst slack | unit | where | t [s] |",
            "|---|---|---|---|---|",
            *[
                f"| {r.family} | {r.worst_slack:.4g} | {r.unit} | {r.where} | {r.time_s:.3f} |"
                for r in checks
            ],
            "",
            f"cond(W_b) (unit-norm columns, {problem.rate_hz:g} Hz grid): {provenance['cond_W_b']:.4g}",
        ]
    )
    (output_dir / "excitation_report.md").write_text(report + "\n")
    motion_figure(
        trajectory.t,
        trajectory.q,
        trajectory.dq,
        trajectory.ddq,
        torque,
        output_dir / "exciting_motion.png",
        f"Optimal exciting motion ({source.criterion.name}, {robot.name})",
    )
    print(report)
    metrics = {
        "cost": result.cost,
        "cond_W_b": float(provenance["cond_W_b"]),
        "optimisation_seconds": result.seconds,
        "iterations": float(result.iterations),
        "violated_families": float(sum(r.violated for r in checks)),
        **{f"worst_slack_{r.family}": r.worst_slack for r in checks},
    }
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics


# --- Fig. 5: duration study -----------------------------------------------------------------------


def knee_duration(
    durations: np.ndarray, costs: np.ndarray, fraction: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """The knee of a cost-vs-duration curve, with the rescaled costs and steps it is read from.

    Rule: rescale the finite costs by their total range ``J_max − J_min``; the knee is the shortest
    duration T such that every later step ``|J(T′) − J(T′ − 1)|`` is below ``fraction`` of that range —
    from T on, a longer motion no longer buys a significant decrease of the criterion.

    Returns
    -------
    knee (s; nan if fewer than two finite costs), relative costs and relative steps (nan for the first).
    """
    costs = np.asarray(costs, dtype=float)
    finite = np.isfinite(costs)
    relative_cost = np.full_like(costs, np.nan)
    relative_step = np.full_like(costs, np.nan)
    if finite.sum() < 2:
        return float("nan"), relative_cost, relative_step
    span = np.ptp(costs[finite]) or 1.0
    relative_cost[finite] = (costs[finite] - costs[finite].min()) / span
    relative_step[1:] = np.abs(np.diff(costs)) / span
    knee_index = int(np.flatnonzero(finite)[0])
    for i in range(1, len(costs)):
        if not (relative_step[i] < fraction):  # nan (an infeasible neighbour) counts as significant
            knee_index = i
    return float(durations[knee_index]), relative_cost, relative_step


def recommended_duration(knees: Mapping[str, float]) -> float:
    """The median of the criteria's knees, rounded up to a whole second (T_F is an integer in the paper).

    The median, not the largest: one criterion whose single-start optima are noisy (or that, like
    ``hadamard``, keeps rewarding sheer length) should not decide the duration for all.
    """
    finite = [k for k in knees.values() if np.isfinite(k)]
    return float(np.ceil(np.median(finite))) if finite else float("nan")


def run_duration_study(
    cfg: Any,
    output_dir: Path,
    criteria: Mapping[str, Criterion],
    durations: Sequence[float] = tuple(range(1, 16)),
    knee_fraction: float = 0.05,
) -> dict[str, float]:
    """Task ``duration_study`` (Fig. 5): optimal cost of every criterion for every duration T_F.

    Writes ``fig5_duration.csv`` with columns ``criterion``, ``duration_s`` (s), ``cost`` (criterion
    at the optimum, unit-free; inf when no feasible motion excites every base parameter),
    ``relative_cost``, ``relative_step`` (see :func:`knee_duration`), ``seconds`` (optimisation wall
    time); ``fig5_duration.md`` (the knees and the recommendation) and ``fig5_duration.png``.
    One duration serves all criteria, as in the paper: :func:`recommended_duration`.
    """
    from hydra.utils import instantiate

    _require_optimal(cfg, criteria)
    robot: RobotModel = instantiate(cfg.robot)
    base = compute_base_parameters(robot)
    durations = [float(d) for d in durations]
    rows = []
    jobs = [(name, duration) for name in criteria for duration in durations]
    for name, duration in tqdm(jobs, desc="duration study", unit="optimisation"):
        source = _optimal_source(cfg, duration=duration, criterion=criteria[name], from_file=None)
        try:
            _, result, _ = source.optimise(robot, base)
            cost, seconds = result.cost, result.seconds
        except InfeasibleExcitationError as error:
            log.warning("%s, %g s: %s", name, duration, error)
            cost, seconds = float("inf"), float("nan")
        rows.append({"criterion": name, "duration_s": duration, "cost": cost, "seconds": seconds})
    table = pd.DataFrame(rows)
    knees = {}
    for name in criteria:
        chosen = table["criterion"] == name
        knee, relative_cost, relative_step = knee_duration(
            table.loc[chosen, "duration_s"].to_numpy(), table.loc[chosen, "cost"].to_numpy(), knee_fraction
        )
        table.loc[chosen, "relative_cost"], table.loc[chosen, "relative_step"] = relative_cost, relative_step
        knees[name] = knee
    recommended = recommended_duration(knees)
    output_dir.mkdir(parents=True, exist_ok=True)
    table.to_csv(output_dir / "fig5_duration.csv", index=False)
    wide = table.pivot(index="duration_s", columns="criterion", values="cost")
    text = "\n".join(
        [
            f"# Optimal cost vs duration ({robot.name}), Fig. 5",
            "",
            wide.to_markdown(floatfmt=".5g"),
            "",
            f"Knee rule: the shortest T_F after which every step |J(T_F) − J(T_F − 1)| stays below {knee_fraction:g} of the "
            "criterion's total decrease.",
            "",
            *[f"- {name}: knee at {knee:g} s" for name, knee in knees.items()],
            "",
            f"Recommended duration (median of the knees, rounded up to a whole second): **{recommended:g} s** "
            "(the paper chose 10 s).",
        ]
    )
    (output_dir / "fig5_duration.md").write_text(text + "\n")
    duration_figure(table, knees, recommended, knee_fraction, output_dir / "fig5_duration.png")
    print(text)
    metrics = {
        "recommended_duration_s": recommended,
        **{f"knee_s_{name}": knee for name, knee in knees.items()},
    }
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics


# --- Fig. 6: criteria comparison ------------------------------------------------------------------


def run_criteria_comparison(
    cfg: Any,
    output_dir: Path,
    criteria: Mapping[str, Criterion],
    seeds: Sequence[int] = (0, 1, 2, 3, 4),
) -> dict[str, float]:
    """Task ``criteria_comparison`` (Fig. 6, §III.E): which criterion's motion identifies best.

    For each criterion, its optimal motion of ``cfg.trajectory.duration`` seconds is played on the
    simulated plant of each seed (a different true robot and noise draw per seed), identified with
    ``cfg.estimator`` and cross-validated on the same motion ``cfg.validation`` (20 s).

    Writes ``fig6_criteria.csv`` with columns ``criterion``, ``seed``, ``joint`` (1…N_J), ``rms``
    (N·m) and ``nrms`` (%) of the cross-validation torque error (measured vs estimated), and, for a
    simulated plant, ``model_rms`` (N·m, true vs estimated: the sensor noise left out);
    ``fig6_parameter_error.csv`` (criterion, seed, base_parameter_error) for a simulated plant;
    ``fig6_criteria.md`` (mean ± std over seeds per criterion and joint, and per criterion over
    joints), ``fig6_criteria.png``.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    from lwrlab.pipeline.identification import identify

    _require_optimal(cfg, criteria)
    robot: RobotModel = instantiate(cfg.robot)
    base = compute_base_parameters(robot)
    processing = OmegaConf.to_container(cfg.measurement.processing, resolve=True)
    motions, optimisation = {}, []
    for name, criterion in tqdm(criteria.items(), desc="optimal motions", unit="criterion"):
        source = _optimal_source(cfg, criterion=criterion, from_file=None)
        motion, result, _ = source.optimise(robot, base)
        motions[name] = motion
        optimisation.append(
            _optimisation_row(
                name, result, regressor_condition(robot, *motion.evaluate(motion.times(100.0)), base)
            )
        )
    rows, parameter_errors = [], []
    jobs = [(name, seed) for name in criteria for seed in seeds]
    for name, seed in tqdm(jobs, desc="identify and cross-validate", unit="run"):
        plant = instantiate(cfg.plant, seed=seed, show_progress=False)(robot=robot)
        report = identify(
            robot=robot,
            motion_source=motions[name],
            validation_source=instantiate(cfg.validation),
            plant=plant,
            estimator=instantiate(cfg.estimator),
            rate_hz=cfg.measurement.rate_hz,
            processing=processing,
            statistics=OmegaConf.to_container(cfg.statistics, resolve=True) if "statistics" in cfg else None,
        )
        model_rms = _model_error(plant, report)
        for (joint, values), model in zip(report.validation.iterrows(), model_rms, strict=True):
            row = {
                "criterion": name,
                "seed": seed,
                "joint": int(joint),
                "rms": float(values["rms"]),
                "nrms": float(values["nrms"]),
            }
            rows.append(row | ({"model_rms": float(model)} if model_rms is not None else {}))
        if "base_parameter_error" in report.metrics:
            parameter_errors.append(
                {
                    "criterion": name,
                    "seed": seed,
                    "base_parameter_error": report.metrics["base_parameter_error"],
                }
            )
    table = pd.DataFrame(rows)
    output_dir.mkdir(parents=True, exist_ok=True)
    table.to_csv(output_dir / "fig6_criteria.csv", index=False)
    metrics_columns = [c for c in ("rms", "nrms", "model_rms") if c in table]
    aggregations = {f"{c}_{f}": (c, f) for c in metrics_columns for f in ("mean", "std")}
    per_joint = table.groupby(["criterion", "joint"], sort=False).agg(**aggregations).reset_index()
    per_run = table.groupby(["criterion", "seed"], sort=False)[metrics_columns].mean().reset_index()
    if parameter_errors:
        per_run = per_run.merge(pd.DataFrame(parameter_errors), on=["criterion", "seed"])
        pd.DataFrame(parameter_errors).to_csv(output_dir / "fig6_parameter_error.csv", index=False)
    run_columns = [c for c in per_run.columns if c not in ("criterion", "seed")]
    overall = per_run.groupby("criterion", sort=False).agg(
        **{f"{c}_{f}": (c, f) for c in run_columns for f in ("mean", "std")}
    )
    overall = overall.join(pd.DataFrame(optimisation).set_index("criterion"))
    ranking_by = "model_rms_mean" if "model_rms_mean" in overall else "rms_mean"
    ranking = overall.sort_values(ranking_by).index.tolist()
    text = "\n".join(
        [
            f"# Criteria comparison ({robot.name}, {len(seeds)} seeds), Fig. 6",
            "",
            "Mean over joints of the cross-validation error, mean ± std over seeds:",
            "",
            _format_mean_std(overall).to_markdown(),
            "",
            "Per joint, mean ± std over seeds:",
            "",
            _format_mean_std(per_joint.set_index(["criterion", "joint"])).unstack("criterion").to_markdown(),
            "",
            "rms, nrms: measured (noisy) vs estimated torque, as in the paper; model_rms: true (noise-free) vs estimated "
            "torque, the model's own error; base_parameter_error: ‖φ̂_b − φ_b‖/‖φ_b‖ against the simulated truth.",
            "",
            f"Ranking by mean {ranking_by.removesuffix('_mean')}: {' < '.join(ranking)} "
            "(the paper, measured RMS on the real robot: logdet 0.42 < hadamard 0.45 < cond 0.69 N·m).",
        ]
    )
    (output_dir / "fig6_criteria.md").write_text(text + "\n")
    criteria_figure(per_joint, output_dir / "fig6_criteria.png")
    print(text)
    metrics = {f"rms_mean_{name}": float(overall.loc[name, "rms_mean"]) for name in overall.index}
    metrics |= {f"nrms_mean_{name}": float(overall.loc[name, "nrms_mean"]) for name in overall.index}
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics


def _model_error(plant: Any, report: Any) -> np.ndarray | None:
    """RMS (N·m) per joint of estimated minus *true* torque on the validation samples, if the plant knows its truth.

    The measured RMS of the paper bottoms out at the sensor noise; this one shows the model's error itself.
    """
    truth = getattr(plant, "truth", None)
    if truth is None:
        return None
    motion = report.validation_motion
    index = np.clip(np.searchsorted(motion.t, report.validation_times - 1e-9), 0, len(motion.t) - 1)
    true_torque = truth.robot.inverse_dynamics(motion.q[index], motion.dq[index], motion.ddq[index])
    return np.sqrt(np.mean((report.validation_estimated - true_torque) ** 2, axis=0))


def _optimisation_row(name: str, result: ExcitationResult, condition: float) -> dict[str, float | str]:
    return {"criterion": name, "cost": result.cost, "cond_W_b": condition, "optimisation_s": result.seconds}


def _format_mean_std(frame: pd.DataFrame) -> pd.DataFrame:
    """Pairs of ``<m>_mean``/``<m>_std`` columns as ``mean ± std`` strings; other columns kept."""
    out = pd.DataFrame(index=frame.index)
    for column in frame.columns:
        if column.endswith("_mean"):
            metric = column.removesuffix("_mean")
            out[metric] = [
                f"{m:.4g} ± {s:.2g}"
                for m, s in zip(frame[column], frame[f"{metric}_std"].fillna(0.0), strict=True)
            ]
        elif not column.endswith("_std"):
            out[column] = frame[column].map(lambda v: f"{v:.4g}")
    return out
