"""Task ``duration_study`` (Fig. 5, preset ``experiment=paper_fig5_duration``): the knee of cost vs duration.

The optimal cost of every criterion for every duration T_F of the exciting motion
(``trajectory=optimal``), the knee of each cost curve (:func:`knee_duration`) and the one duration
recommended for all criteria (:func:`recommended_duration`).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.solver import InfeasibleExcitationError
from lwrlab.figures.excitation import duration_figure
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.excitation import optimal_source, require_optimal

log = logging.getLogger(__name__)


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

    require_optimal(cfg, criteria)
    robot: RobotModel = instantiate(cfg.robot)
    base = compute_base_parameters(robot)
    durations = [float(d) for d in durations]
    rows = []
    jobs = [(name, duration) for name in criteria for duration in durations]
    for name, duration in tqdm(jobs, desc="duration study", unit="optimisation"):
        source = optimal_source(cfg, duration=duration, criterion=criteria[name], from_file=None)
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
            "Knee rule: the shortest T_F after which every step |J(T_F) − J(T_F − 1)| stays below "
            f"{knee_fraction:g} of the criterion's total decrease.",
            "",
            *[f"- {name}: knee at {knee:g} s" for name, knee in knees.items()],
            "",
            "Recommended duration (median of the knees, rounded up to a whole second): "
            f"**{recommended:g} s** (the paper chose 10 s).",
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
