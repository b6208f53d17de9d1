"""``lwrlab report``: the paper's tables and figures rebuilt from runs logged in MLflow.

Selects the FINISHED job runs of one or more experiments (``search_runs`` → pandas, filtered by
tags and params: :mod:`lwrlab.tracking.reports.run_selection`), downloads their table artifacts
(``base_parameters.csv``, ``fig5_duration.csv``, ``fig6_criteria.csv``, ``table3_tools.csv``,
``table4_force.csv``), and writes Table II, Fig. 5, Fig. 6, Table III and Table IV as Markdown, CSV
and PNG into a folder under ``outputs/reports/``, which is then logged once as a run of the source
experiment. An artifact kind that no selected run has is skipped with a note; so is a table that
would pool runs differing in a parameter (an estimator, a noise level) that the table does not itself
tell apart: the note names the parameter and its values.
Works on a SQLite store and on a tracking server alike. Artifacts are read as CSV: nothing executes.

Examples
--------
::

    lwrlab report --experiment paper_fig6_criteria
    lwrlab report --experiment identification --param plant.torque_noise_std=0.1 --kinds table2
    lwrlab report --tracking-uri http://127.0.0.1:5000 --experiment paper_table2 --no-log
"""

from __future__ import annotations

import argparse
import datetime as _dt
import logging
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mlflow
import pandas as pd
from mlflow.tracking import MlflowClient

from lwrlab.figures.paper_artifacts import ARTIFACT_KINDS, ArtifactColumnsError, ReportPart
from lwrlab.reference import paper_results
from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG, provenance_tags
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.reports.derived_runs import derived_key, log_derived_run
from lwrlab.tracking.reports.run_groups import short_name, swept_parameters, value_summary
from lwrlab.tracking.reports.run_selection import parse_pairs, select_runs, selection_filter
from lwrlab.tracking.store.sqlite import absolute_tracking_uri, add_tracking_uri_option, retry_locked

log = logging.getLogger(__name__)

# Columns of the artifacts that say which run a row came from, not what it compares.
_PROVENANCE_COLUMNS = frozenset({"run_id", "experiment", "seed"})


@dataclass
class Report:
    """What :func:`build_report` produced."""

    output_dir: Path
    runs: pd.DataFrame
    parts: dict[str, ReportPart] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    """Kind → why it is not in the report."""
    run_id: str | None = None
    """The report run, if logged."""


def artifact_names(client: MlflowClient, runs: pd.DataFrame) -> dict[str, set[str]]:
    """Run id → names of its top-level artifacts (one listing per run)."""
    return {
        str(run_id): {entry.path for entry in retry_locked(client.list_artifacts, str(run_id))}
        for run_id in runs["run_id"]
    }


def collect_artifact(
    client: MlflowClient,
    runs: pd.DataFrame,
    artifact: str,
    download_dir: Path,
    available: Mapping[str, set[str]] | None = None,
) -> pd.DataFrame | None:
    """One artifact CSV of every run that has it, concatenated, with ``run_id``, ``experiment``, ``seed``.

    ``None`` if no run has it. A run whose CSV cannot be read raises ``ValueError`` naming run and file.
    ``available`` (from :func:`artifact_names`) saves listing each run's artifacts again.
    """
    frames = []
    available = artifact_names(client, runs) if available is None else available
    seeds = dict(
        zip(runs["run_id"], runs["tags.seed"] if "tags.seed" in runs else [None] * len(runs), strict=True)
    )
    for row in runs.itertuples(index=False):
        run_id = str(row.run_id)
        if artifact not in available.get(run_id, set()):
            continue
        local = Path(
            mlflow.artifacts.download_artifacts(
                run_id=run_id,
                artifact_path=artifact,
                dst_path=str(download_dir / run_id),
                tracking_uri=client.tracking_uri,
            )
        )
        try:
            frame = pd.read_csv(local)
        except Exception as error:
            raise ValueError(f"run {run_id}, artifact {artifact}: unreadable CSV ({error})") from error
        frame.insert(0, "run_id", run_id)
        frame.insert(1, "experiment", getattr(row, "experiment", ""))
        if "seed" not in frame.columns:
            frame.insert(2, "seed", seeds[run_id])
        frames.append(frame)
    return pd.concat(frames, ignore_index=True) if frames else None


def build_report(
    tracking_uri: str,
    output_dir: Path,
    experiments: Sequence[str] | None = None,
    filter_string: str = "",
    kinds: Sequence[str] | None = None,
) -> Report:
    """Rebuild the paper's artifacts from the selected runs and write them into ``output_dir``.

    Parameters
    ----------
    tracking_uri
        The MLflow store (SQLite URI, server URL, …).
    output_dir
        Folder for ``report.md``, the CSV tables and the PNG figures (created).
    experiments
        Experiment names; ``None`` = every experiment but ``reports``.
    filter_string
        Full MLflow filter (see :func:`selection_filter`).
    kinds
        Subset of ``table2``, ``fig5``, ``fig6``, ``table3``, ``table4`` (default: all).
    """
    unknown = sorted(set(kinds or []) - set(ARTIFACT_KINDS))
    if unknown:
        raise ValueError(f"unknown report kind(s) {unknown}; valid: {sorted(ARTIFACT_KINDS)}")
    output_dir.mkdir(parents=True, exist_ok=True)
    runs = select_runs(tracking_uri, experiments, filter_string)
    report = Report(output_dir=output_dir, runs=runs)
    client = MlflowClient(tracking_uri=tracking_uri)
    paper = paper_results()
    available = {} if runs.empty else artifact_names(client, runs)
    differing = swept_parameters(runs)
    with tempfile.TemporaryDirectory(prefix="lwrlab_report_") as download_dir:
        for kind in kinds or ARTIFACT_KINDS:
            artifact, builder = ARTIFACT_KINDS[kind]
            frame = (
                None
                if runs.empty
                else collect_artifact(client, runs, artifact, Path(download_dir), available)
            )
            if frame is None:
                report.skipped[kind] = f"no selected run has `{artifact}`"
                log.warning("%s skipped: %s", kind, report.skipped[kind])
                continue
            pooled = unseparated_parameters(differing, frame)
            if pooled:
                report.skipped[kind] = pooling_refusal(runs, pooled)
                log.warning("%s refused: %s", kind, report.skipped[kind])
                continue
            try:
                part = builder(frame, paper, output_dir)
            except ArtifactColumnsError as error:
                report.skipped[kind] = str(error)
                log.warning("%s skipped: %s", kind, error)
                continue
            for name, table in part.tables.items():
                table.to_csv(output_dir / f"{name}.csv")
            report.parts[kind] = part
    _write_markdown(report, experiments, filter_string, tracking_uri)
    if not runs.empty:
        columns = [
            c
            for c in ("run_id", "experiment", "status", "tags.overrides", "tags.seed", "tags.config_hash")
            if c in runs
        ]
        runs[columns].to_csv(output_dir / "runs.csv", index=False)
    return report


def unseparated_parameters(differing: Sequence[str], frame: pd.DataFrame) -> list[str]:
    """The parameters runs differ in that ``frame`` has no column for (a table would pool across them).

    A parameter counts as told apart when the artifact has a column of its short name, or a column
    of labels its short name ends with (``fixture_criterion`` by ``criterion``, as Fig. 6 groups by
    criterion); a numeric column (``std``) labels nothing.
    """
    columns = [str(column) for column in frame.columns if column not in _PROVENANCE_COLUMNS]
    labels = [column for column in columns if not pd.api.types.is_numeric_dtype(frame[column])]
    return [
        parameter
        for parameter in differing
        if short_name(parameter) not in columns
        and not any(short_name(parameter).endswith("_" + column) for column in labels)
    ]


def pooling_refusal(runs: pd.DataFrame, parameters: Sequence[str]) -> str:
    """Why a table is not built: the parameters the runs differ in, their values, and what to do."""
    listed = "; ".join(f"{parameter} ({value_summary(runs, parameter)})" for parameter in parameters)
    example = parameters[0]
    return (
        f"the selected runs differ in {listed}; one table would pool them. Select one value, e.g. "
        f"`--param {example}=<value>`, or compare them with `lwrlab compare`"
    )


def _write_markdown(
    report: Report, experiments: Sequence[str] | None, filter_string: str, tracking_uri: str
) -> Path:
    lines = [
        "# lwrlab report",
        "",
        f"- store: `{Redactor().redact(tracking_uri)}`",
        f"- experiments: {', '.join(experiments) if experiments else 'all'}",
        f"- filter: `{filter_string}`",
        f"- runs selected: {len(report.runs)}",
        "",
    ]
    for part in report.parts.values():
        lines += [f"## {part.title}", "", part.markdown, ""]
    for kind, reason in report.skipped.items():
        lines.append(f"- {kind} skipped: {reason}")
    path = report.output_dir / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def log_report(
    report: Report, tracking_uri: str, experiments: Sequence[str] | None, filter_string: str
) -> tuple[str, bool] | None:
    """Log the report folder once, as a run of its source experiment.

    Returns
    -------
    tuple[str, bool] or None
        The run id and whether it was logged now (``False``: the same report of the same runs was
        logged before); ``None`` when the runs come from several experiments (nothing is logged).
    """
    sources = sorted(set(report.runs["experiment"])) if not report.runs.empty else list(experiments or [])
    if len(sources) != 1:
        return None
    client = MlflowClient(tracking_uri=tracking_uri)
    experiment = retry_locked(client.get_experiment_by_name, sources[0])
    if experiment is None:
        return None
    tags = {
        RUN_KIND_TAG: "report",
        "source_experiments": ",".join(experiments or ["all"]),
        "filter": filter_string[:5000],
        "source_runs": str(len(report.runs)),
        "kinds": ",".join(report.parts),
        "skipped": "; ".join(f"{k}: {v}" for k, v in report.skipped.items())[:5000],
        **provenance_tags(Path.cwd()),
    }
    source_ids = list(report.runs["run_id"]) if not report.runs.empty else []
    key = derived_key("report", source_ids, {"filter": filter_string, "kinds": sorted(report.parts)})
    return log_derived_run(
        client,
        experiment.experiment_id,
        key,
        report.output_dir,
        f"report · {', '.join(report.parts) or 'empty'}",
        tags,
    )


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``lwrlab report`` (the README's commands are parsed with it in the tests)."""
    parser = argparse.ArgumentParser(prog="lwrlab report", description=__doc__.split("\n\n")[0])
    add_tracking_uri_option(parser)
    parser.add_argument("--experiment", action="append", help="experiment name (repeatable; default: all)")
    parser.add_argument(
        "--tag", action="append", default=[], metavar="KEY=VALUE", help="keep runs with this tag"
    )
    parser.add_argument(
        "--param", action="append", default=[], metavar="KEY=VALUE", help="keep runs with this param"
    )
    parser.add_argument("--filter", default="", help='extra MLflow filter, e.g. "metrics.rms_mean < 0.5"')
    parser.add_argument(
        "--kinds",
        default=",".join(ARTIFACT_KINDS),
        help=f"comma-separated subset of {','.join(ARTIFACT_KINDS)}",
    )
    parser.add_argument(
        "--output", type=Path, default=None, help="output folder (default: outputs/reports/<time>)"
    )
    parser.add_argument("--no-log", action="store_true", help="do not log the report as an MLflow run")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``lwrlab report ...``; returns the process exit status."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    uri = absolute_tracking_uri(arguments.tracking_uri, Path.cwd())
    output = arguments.output or Path("outputs") / "reports" / _dt.datetime.now().strftime(
        "%Y-%m-%d_%H-%M-%S"
    )
    filter_string = selection_filter(
        parse_pairs(arguments.tag, "tag"), parse_pairs(arguments.param, "param"), arguments.filter
    )
    kinds = [kind.strip() for kind in arguments.kinds.split(",") if kind.strip()]
    try:
        report = build_report(uri, output, arguments.experiment, filter_string, kinds)
    except ValueError as error:
        parser.error(str(error))
    print((output / "report.md").read_text(encoding="utf-8"))
    if not arguments.no_log:
        logged = log_report(report, uri, arguments.experiment, filter_string)
        if logged is None:
            print("report not logged: its runs come from several experiments (name one with --experiment)")
        else:
            report.run_id = logged[0]
            experiment = (
                report.runs["experiment"].iloc[0] if not report.runs.empty else arguments.experiment[0]
            )
            print(
                f"report {'logged as' if logged[1] else 'already logged as'} run {report.run_id} "
                f"of experiment {experiment!r}"
            )
    print(f"report written to {output}")
    return 0


__all__ = [
    "Report",
    "artifact_names",
    "build_report",
    "collect_artifact",
    "log_report",
    "main",
    "pooling_refusal",
    "unseparated_parameters",
]
