"""Writes a :class:`~lwrlab.pipeline.painting.PaintingReport`: Table IV, paths, runs, figures, metrics.

The tracking callback logs the folder to MLflow, so nothing here knows about MLflow or Hydra.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import pandas as pd

from lwrlab.figures.painting import normal_force, path_on_wall
from lwrlab.pipeline.painting.runs import ScoredRun

if TYPE_CHECKING:  # the stage calls this writer; the writer only reads the stage's report type
    from lwrlab.pipeline.painting.task import PaintingReport

CONTACT_DECIMATION = 10
"""Every 10th sample of a run goes to ``contact_*.npz``: 100 Hz, the figures' resolution, a few MB per run."""


def save_contact_run(scored: ScoredRun, path: Path) -> Path:
    """The run at 100 Hz (reference, commanded and actual positions, wrenches, joints) as npz."""
    run, every = scored.run, slice(None, None, CONTACT_DECIMATION)
    np.savez_compressed(
        path,
        t=run.t[every],
        reference=run.reference[every],
        commanded=run.commanded[every],
        actual=run.actual[every],
        estimated_wrench=run.estimated_wrench[every],
        measured_force=run.measured_force[every],
        q=run.q[every],
        q_desired=run.q_desired[every],
        tau=run.tau[every],
        painting=run.painting[every],
    )
    return path


def roller_figures(report: PaintingReport, roller: str, output_dir: Path) -> tuple[Path, Path]:
    """Fig. 12 (the path on the wall) and Fig. 13 (the normal forces) of one roller, like the paper's."""
    runs = {(run.model, run.feedback): run for run in report.runs if run.roller == roller}
    main = runs.get(("identified", "estimate")) or next(iter(runs.values()))
    wall = report.wall
    fig12 = path_on_wall(
        main.run.reference[main.run.painting],
        main.run.actual[main.run.painting],
        (*wall.y_bounds, *wall.z_bounds),
        output_dir / f"fig12_{roller}.png",
        f"{roller}: desired vs actual path",
    )
    panels = {
        f"{model} model, {feedback} feedback": {k: run.forces[k] for k in ("estimated", "measured")}
        for (model, feedback), run in runs.items()
        if model != "position"
    }
    t_painting = main.forces["t"]
    fig13 = normal_force(
        t_painting - t_painting[0],
        panels,
        report.desired_force,
        output_dir / f"fig13_{roller}.png",
        f"{roller}: normal force on the wall",
    )
    return fig12, fig13


def write_painting(report: PaintingReport, output_dir: Path) -> dict[str, Path]:
    """Write the painting report's tables, runs, figures, summary and metrics into ``output_dir``.

    Files: ``table4_force.csv`` with columns ``roller, model, feedback, comparison, rms,
    rms_over_mean_pct`` (model: ``identified`` | ``cad`` | ``position`` (the comparison position
    controller, identified model); feedback: ``estimate`` | ``sensor`` | ``none``; comparison:
    ``estimated/measured``, ``estimated/desired``, ``measured/desired`` of the normal force F_x over
    the painting path (the last two only for a controller with a desired force); rms in N,
    rms_over_mean_pct: the RMS in % of the second signal's mean magnitude, the paper's Table IV
    "NRMS"), ``painting_paths.csv`` (per roller: the eq. (12) solution x = [T_C, φ, Z_u, Z_l, Y_0,
    ΔY], N_r, branch, cost terms, painted area (m²), recognised tool and w_L, optimisation time),
    ``painting_runs.csv`` (per run: coverage of the planned area from the contact trace, its worst
    interior column (2 mm cells, 1 cm from the sides left out) and worst row, path tracking RMS in
    the wall plane (m), mean normal forces, simulation time), ``contact_<roller>_<model>_<feedback>.npz``
    (:func:`save_contact_run`), ``fig12_<roller>.png``, ``fig13_<roller>.png``, ``summary.md`` and
    ``metrics.json``.
    """
    output_dir.mkdir(parents=True, exist_ok=True)
    files = {
        f"contact_{run.key}": save_contact_run(run, output_dir / f"contact_{run.key}.npz")
        for run in report.runs
    }
    for roller in report.plans:
        files[f"fig12_{roller}"], files[f"fig13_{roller}"] = roller_figures(report, roller, output_dir)
    for name, table in (
        ("table4_force", report.force_errors),
        ("painting_runs", report.run_summary),
        ("painting_paths", report.path_summary),
    ):
        files[name] = output_dir / f"{name}.csv"
        table.to_csv(files[name], index=False)
    files["summary"] = output_dir / "summary.md"
    files["summary"].write_text(format_painting(report) + "\n")
    files["metrics"] = output_dir / "metrics.json"
    files["metrics"].write_text(json.dumps(report.metrics, indent=2))
    return files


def format_table4(table: pd.DataFrame) -> str:
    """Table IV as Markdown: one row per model, feedback and comparison, RMS and RMS/mean per roller."""
    wide = table.pivot_table(
        index=["model", "feedback", "comparison"],
        columns="roller",
        values=["rms", "rms_over_mean_pct"],
        sort=False,
    )
    columns = [f"{roller} {stat}" for stat, roller in cast(list[tuple[str, str]], wide.columns.tolist())]
    wide.columns = pd.Index(columns)
    ordered: list[str] = sorted(columns, key=lambda c: (c.split()[0], c.split()[1] != "rms"))  # rms first
    wide = wide[ordered]
    return wide.reset_index().to_markdown(index=False, floatfmt=".3g")


def format_painting(report: PaintingReport) -> str:
    """Table IV, the optimised paths and the runs, as Markdown."""
    return "\n".join(
        [
            "## Table IV: normal external force (RMS in N, RMS over the mean force magnitude in %)",
            "",
            format_table4(report.force_errors),
            "",
            "## Optimised painting paths (eq. 12)",
            "",
            report.path_summary.drop(columns=["active_constraints"]).to_markdown(index=False, floatfmt=".4g"),
            "",
            "## Painting runs",
            "",
            report.run_summary.to_markdown(index=False, floatfmt=".4g"),
        ]
    )
