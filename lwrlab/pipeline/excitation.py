"""Task ``excitation`` (Katsumata et al. §III): optimise one exciting motion and write it.

The three exciting-motion tasks (config group ``task``), each ``f(cfg, output_dir) -> metrics``, read
the excitation settings from ``cfg.trajectory``, which must be ``trajectory=optimal``
(:func:`require_optimal`):

* ``excitation`` (:func:`run_excitation`, here): optimise the motion, write it
  (``exciting_motion.yaml`` + 1 kHz ``exciting_motion.csv``), its report and figure;
* ``duration_study`` (:mod:`lwrlab.pipeline.duration_study`, preset ``experiment=paper_fig5_duration``):
  the optimal cost of each criterion for each duration T_F, ``fig5_duration.csv`` and the knee rule;
* ``criteria_comparison`` (:mod:`lwrlab.pipeline.criteria_comparison`, preset
  ``experiment=paper_fig6_criteria``): each criterion's optimum → simulated measurement →
  identification → cross-validation, over seeds, ``fig6_criteria.csv``.
"""

from __future__ import annotations

import json
import logging
import shlex
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.solver import verify_motion
from lwrlab.figures.excitation import motion_figure
from lwrlab.io.artifacts import save_trajectory_csv
from lwrlab.io.exciting_motion import save_motion_description
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra

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


def run_excitation(cfg: Any, output_dir: Path, verify_rate_hz: float = 1000.0) -> dict[str, float]:
    """Task ``excitation``: optimise the exciting motion of ``cfg.robot`` and write it.

    Writes ``exciting_motion.yaml`` (parameterisation and coefficients, loadable with
    ``trajectory.from_file=…``), ``exciting_motion.csv`` (t, q, q̇, q̈ at ``verify_rate_hz``),
    ``excitation_report.md`` (criterion, worst slack per constraint family on the optimisation grid and
    at ``verify_rate_hz``), ``exciting_motion.png`` and ``metrics.json``.
    """
    from hydra.utils import instantiate

    robot: RobotModel = instantiate(cfg.robot)
    source = optimal_source(cfg)
    motion, result, problem = source.optimise(robot)
    q, dq, ddq = (b @ result.coefficients for b in problem.bases)
    checks = verify_motion(robot, motion, source.constraints, verify_rate_hz)
    trajectory = motion.sample(robot, verify_rate_hz)
    torque = robot.inverse_dynamics(trajectory.q, trajectory.dq, trajectory.ddq)
    output_dir.mkdir(parents=True, exist_ok=True)
    provenance = {
        "robot": robot.name,
        "criterion": source.criterion.name,
        "cost": result.cost,
        "cond_W_b": regressor_condition(robot, q, dq, ddq, problem.base),
        "worst_slack_at_verify_rate": {r.family: f"{r.worst_slack:.4g} {r.unit}" for r in checks},
        "verify_rate_hz": verify_rate_hz,
        "optimisation_seconds": round(result.seconds, 2),
        "command": _command_line(),
    }
    save_motion_description(motion.to_dict(), output_dir / "exciting_motion.yaml", provenance)
    save_trajectory_csv(trajectory, output_dir / "exciting_motion.csv")
    report = "\n".join(
        [
            f"# Optimal exciting motion: {robot.name}, {source.criterion.name}, "
            f"{motion.duration:g} s {motion.kind}",
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
