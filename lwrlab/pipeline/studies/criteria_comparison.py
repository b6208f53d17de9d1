"""Task ``criteria_comparison`` (Fig. 6, §III.E, preset ``experiment=paper_fig6_criteria``).

Which criterion's exciting motion identifies best: each criterion's optimum (``trajectory=optimal``)
→ simulated measurement → identification → cross-validation, over seeds.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.solver import ExcitationResult
from lwrlab.figures.excitation import criteria_figure
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings, statistics_settings
from lwrlab.pipeline.excitation import optimal_source, regressor_condition, require_optimal
from lwrlab.pipeline.identification import IdentificationReport, identify
from lwrlab.plants.core import Plant


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

    require_optimal(cfg, criteria)
    robot: RobotModel = instantiate(cfg.robot)
    base = compute_base_parameters(robot)
    processing = processing_settings(cfg)
    motions, optimisation = {}, []
    for name, criterion in tqdm(criteria.items(), desc="optimal motions", unit="criterion"):
        source = optimal_source(cfg, criterion=criterion, from_file=None)
        motion, result, _ = source.optimise(robot, base)
        motions[name] = motion
        q, dq, ddq = motion.evaluate(motion.times(100.0))
        optimisation.append(_optimisation_row(name, result, regressor_condition(robot, q, dq, ddq, base)))
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
            statistics=statistics_settings(cfg),
        )
        model_rms = _model_error(plant, report)
        validation = report.validation
        for k, (joint, rms, nrms) in enumerate(
            zip(validation.index.to_numpy(), validation["rms"], validation["nrms"], strict=True)
        ):
            row = {
                "criterion": name,
                "seed": seed,
                "joint": int(joint),
                "rms": float(rms),
                "nrms": float(nrms),
            }
            rows.append(row | ({"model_rms": float(model_rms[k])} if model_rms is not None else {}))
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
            "rms, nrms: measured (noisy) vs estimated torque, as in the paper; model_rms: true (noise-free) "
            "vs estimated torque, the model's own error; base_parameter_error: ‖φ̂_b − φ_b‖/‖φ_b‖ against "
            "the simulated truth.",
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


def _model_error(plant: Plant, report: IdentificationReport) -> np.ndarray | None:
    """RMS (N·m) per joint of estimated minus *true* torque on the validation samples.

    None unless the plant knows its truth and played the validation motion. The measured RMS of the
    paper bottoms out at the sensor noise; this one shows the model's error itself.
    """
    truth = plant.truth
    motion = report.validation_motion
    if truth is None or motion is None:
        return None
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
