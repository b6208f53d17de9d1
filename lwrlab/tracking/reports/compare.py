"""``lwrlab compare``: the headline metrics of an experiment or a sweep, grouped by what was swept.

Selects the FINISHED job runs of an experiment (or the nested runs of one sweep's parent run),
finds the parameters they differ in (config-group choices by their short names, ``estimator``; the
seed is replication), and writes under ``outputs/compare/``:

* ``compare.md`` and ``compare.csv``: one row per group, the number of runs and seeds, and each
  headline metric (``rms_mean`` [N·m], ``nrms_mean`` [%], ``validation_rel_error``,
  ``base_parameter_error``, timings [s]) as mean ± standard deviation over the group's runs;
* ``rms_per_joint.png``: the cross-validation RMS per joint, one bar per group, ± its spread;
* ``runs.csv``: the runs compared;
* ``compare.html``: all of it on one self-contained page (sortable tables, the figure inline).

Metric names are plain (``rms_mean``), as in each run's ``metrics.json``; runs that logged them under
their MLflow section (``accuracy/rms_mean``) and older runs without one are read alike.

The folder is logged once as a run of the compared experiment (nested under the sweep's parent when
one is compared), with the table as metrics ``<group>/<metric>`` (``estimator:ols/rms_mean``: the
group's mean; ``<group>/runs``) and as MLflow's table artifact ``compare_table.json``, so that the
comparison run's row in the runs table shows its figures; the same comparison of the same runs is not
logged twice. After the table it prints where to see the runs in MLflow's model-training view (MLflow
3.17 opens a new browser on its GenAI view whatever the experiment's kind): the URL for a server, the
``mlflow ui`` command and the URL for a local store, on the port given by ``--ui-port``.

Examples
--------
::

    lwrlab compare --experiment identification
    lwrlab compare --experiment identification --param estimator=sdp --by plant.torque_noise_std
    lwrlab compare --parent 5f0c… --no-log
    lwrlab compare --experiment identification --ui-port 5001
"""

from __future__ import annotations

import argparse
import datetime as _dt
import logging
import re
import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.config_params import mlflow_key
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS, PER_JOINT_RMS, is_timing_metric
from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG, provenance_tags
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.reports.compare_html import comparison_page
from lwrlab.tracking.reports.derived_runs import derived_key, log_derived_run
from lwrlab.tracking.reports.run_groups import PARAM_PREFIX, swept_parameters
from lwrlab.tracking.reports.run_selection import parse_pairs, select_runs, selection_filter
from lwrlab.tracking.store.connection import without_userinfo
from lwrlab.tracking.store.sqlite import (
    absolute_tracking_uri,
    add_tracking_uri_option,
    retry_locked,
    sqlite_database_path,
)

log = logging.getLogger(__name__)

METRIC_PREFIX = "metrics."
ALL_RUNS = "all runs"
MLFLOW_UI_HOST = "127.0.0.1"
MLFLOW_UI_PORT = 5000
MLFLOW_UI_ADDRESS = f"http://{MLFLOW_UI_HOST}:{MLFLOW_UI_PORT}"
"""Where ``mlflow ui`` serves by default."""
TABLE_ARTIFACT = "compare_table.json"
"""The comparison table as MLflow's table artifact (shown as a table in the artifact view)."""


@dataclass
class Comparison:
    """What :func:`compare_runs` found."""

    runs: pd.DataFrame
    groups: list[str]
    """Parameters the rows are grouped by (``[]``: one row, every run)."""
    table: pd.DataFrame
    """One row per group: ``runs``, ``seeds``, ``<metric>`` (mean) and ``<metric>_std`` per metric."""
    metrics: list[str]


def headline_metrics(runs: pd.DataFrame) -> list[str]:
    """The headline and timing metrics present in ``runs``, headline ones first."""
    present = [column[len(METRIC_PREFIX) :] for column in runs.columns if column.startswith(METRIC_PREFIX)]
    ordered = [metric for metric in HEADLINE_METRICS if metric in present]
    return ordered + sorted(metric for metric in present if is_timing_metric(metric))


def _group_labels(runs: pd.DataFrame, groups: Sequence[str]) -> pd.Series:
    if not groups:
        return pd.Series(ALL_RUNS, index=runs.index)
    parts = [groups_value(runs, group).radd(f"{group}=") for group in groups]
    label = parts[0]
    for part in parts[1:]:
        label = label + ", " + part
    return label


def groups_value(runs: pd.DataFrame, group: str) -> pd.Series:
    """A group parameter's values as text (``<unset>`` where a run lacks it)."""
    return runs[PARAM_PREFIX + group].fillna("<unset>").astype(str)


def compare_runs(runs: pd.DataFrame, groups: Sequence[str] | None = None) -> Comparison:
    """Group ``runs`` by ``groups`` (default: the parameters they differ in) and summarise their metrics.

    Parameters
    ----------
    runs
        FINISHED job runs (``mlflow.search_runs`` layout).
    groups
        Parameter keys to group by; ``None`` finds them with :func:`swept_parameters`.

    Returns
    -------
    Comparison
        ``table`` has one row per group, in the groups' sorted order: ``runs`` (count), ``seeds``
        (distinct seeds), and for each metric its mean and its sample standard deviation over the
        group's runs (``nan`` for a single run).
    """
    groups = list(swept_parameters(runs) if groups is None else groups)
    missing = [group for group in groups if PARAM_PREFIX + group not in runs]
    if missing:
        known = sorted(
            column[len(PARAM_PREFIX) :] for column in runs.columns if column.startswith(PARAM_PREFIX)
        )
        raise ValueError(f"no run has the parameter(s) {missing}; parameters: {known[:40]}")
    metrics = headline_metrics(runs)
    labels = _group_labels(runs, groups)
    seeds = runs["params.seed"] if "params.seed" in runs else pd.Series("", index=runs.index)
    rows = []
    for label in sorted(labels.unique()):
        members = runs[labels == label]
        row: dict[str, object] = {"group": label}
        row.update({group: groups_value(members, group).iloc[0] for group in groups})
        row.update(runs=len(members), seeds=int(seeds[labels == label].nunique()))
        for metric in metrics:
            values = pd.to_numeric(members[METRIC_PREFIX + metric], errors="coerce").dropna()
            row[metric] = float(values.mean()) if len(values) else np.nan
            row[f"{metric}_std"] = float(values.std(ddof=1)) if len(values) > 1 else np.nan
        rows.append(row)
    table = pd.DataFrame(rows).set_index("group")
    return Comparison(runs=runs, groups=groups, table=table, metrics=metrics)


def _unit(metric: str) -> str:
    if metric in HEADLINE_METRICS:
        return HEADLINE_METRICS[metric][0]
    return "s" if is_timing_metric(metric) else ""


def to_markdown(comparison: Comparison) -> str:
    """The comparison as a Markdown table: mean ± std with units in the headers."""
    table = comparison.table
    shown = pd.DataFrame(index=table.index)
    shown["runs"] = table["runs"]
    shown["seeds"] = table["seeds"]
    for metric in comparison.metrics:
        mean, std = table[metric], table[f"{metric}_std"]
        shown[f"{metric} [{_unit(metric)}]"] = [
            "–" if np.isnan(m) else (f"{m:.4g}" if np.isnan(s) else f"{m:.4g} ± {s:.2g}")
            for m, s in zip(mean, std, strict=True)
        ]
    return shown.to_markdown()


def per_joint_rms(runs: pd.DataFrame, labels: pd.Series) -> tuple[np.ndarray, np.ndarray, list[str]] | None:
    """Mean and std over each group's runs of ``rms_joint1…N``; ``None`` if the runs have no per-joint RMS."""
    columns = sorted(
        (int(match.group(1)), column)
        for column in runs.columns
        if column.startswith(METRIC_PREFIX) and (match := PER_JOINT_RMS.match(column[len(METRIC_PREFIX) :]))
    )
    if not columns:
        return None
    names = [column for _, column in columns]
    groups = sorted(labels.unique())
    values = [runs.loc[labels == group, names].apply(pd.to_numeric, errors="coerce") for group in groups]
    mean = np.array([frame.mean().to_numpy() for frame in values])
    spread = np.array(
        [frame.std(ddof=1).to_numpy() if len(frame) > 1 else np.full(len(names), np.nan) for frame in values]
    )
    return mean, spread, groups


def write_comparison(comparison: Comparison, output_dir: Path, title: str) -> list[Path]:
    """Write ``compare.md``, ``compare.csv``, ``runs.csv``, ``compare.html`` and, given per-joint RMS,
    ``rms_per_joint.png``; return the files written."""
    from lwrlab.figures.torques import rms_per_joint_by_group

    output_dir.mkdir(parents=True, exist_ok=True)
    grouped_by = ", ".join(comparison.groups) or "nothing (the runs do not differ)"
    markdown = "\n".join(
        [
            f"# {title}",
            "",
            f"- runs: {len(comparison.runs)} FINISHED job runs; grouped by {grouped_by}; "
            "seeds pooled as replication",
            "- mean ± sample standard deviation over each group's runs",
            "",
            to_markdown(comparison),
            "",
        ]
    )
    written = [output_dir / "compare.md", output_dir / "compare.csv", output_dir / "runs.csv"]
    written[0].write_text(markdown, encoding="utf-8")
    comparison.table.to_csv(written[1])
    columns = [
        c
        for c in (
            "run_id",
            "experiment",
            "tags.mlflow.runName",
            "params.seed",
            *(PARAM_PREFIX + g for g in comparison.groups),
        )
        if c in comparison.runs
    ]
    runs_compared = comparison.runs[columns + [METRIC_PREFIX + m for m in comparison.metrics]]
    runs_compared.to_csv(written[2], index=False)
    joints = per_joint_rms(comparison.runs, _group_labels(comparison.runs, comparison.groups))
    figures = []
    if joints is not None:
        mean, spread, labels = joints
        figures.append(rms_per_joint_by_group(mean, spread, labels, output_dir / "rms_per_joint.png", title))
    page = comparison_page(
        title,
        comparison.table,
        comparison.metrics,
        {metric: _unit(metric) for metric in comparison.metrics},
        runs_compared.rename(columns=_shown_column),
        figures,
        notes=[
            f"{len(comparison.runs)} FINISHED job runs; grouped by {grouped_by}; seeds pooled as replication"
        ],
    )
    (output_dir / "compare.html").write_text(page, encoding="utf-8")
    return [*written, *figures, output_dir / "compare.html"]


def _shown_column(column: str) -> str:
    """A ``search_runs`` column as a reader names it: ``params.seed`` → ``seed``, the run name → ``run``."""
    if column == "tags.mlflow.runName":
        return "run"
    for prefix in (PARAM_PREFIX, METRIC_PREFIX):
        if column.startswith(prefix):
            return column[len(prefix) :]
    return column


def group_key(label: str) -> str:
    """A group's label as the first part of an MLflow metric key: ``estimator=ols`` → ``estimator:ols``.

    Examples
    --------
    >>> group_key("estimator=ols, plant.torque_noise_std=0.1")
    'estimator:ols plant.torque_noise_std:0.1'
    """
    return mlflow_key(label.replace("=", ":").replace(", ", " "))


def _json_table(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with ``nan`` as ``None``: MLflow's table artifact is JSON, which has no NaN."""
    return table.astype(object).where(pd.notna(table), None)


def comparison_metrics(comparison: Comparison) -> dict[str, float]:
    """The table as metrics of the comparison run: ``<group>/<metric>`` (the mean) and ``<group>/runs``."""
    metrics: dict[str, float] = {}
    for label, row in comparison.table.iterrows():
        key = group_key(str(label))
        metrics[f"{key}/runs"] = float(row["runs"])
        for metric in comparison.metrics:
            if pd.notna(row[metric]):
                metrics[f"{key}/{metric}"] = float(row[metric])
    return metrics


def runs_view_path(experiment_id: str) -> str:
    """The UI path of an experiment's runs in MLflow's model-training view (not its GenAI view).

    Examples
    --------
    >>> runs_view_path("3")
    '/#/experiments/3/runs?workflowType=machine_learning'
    """
    return f"/#/experiments/{experiment_id}/runs?workflowType=machine_learning"


def runs_view_hint(tracking_uri: str, experiment_id: str, ui_port: int = MLFLOW_UI_PORT) -> str | None:
    """How to open an experiment's runs in MLflow's UI: a server's URL, or ``mlflow ui`` for a local store.

    Parameters
    ----------
    tracking_uri
        The store, absolute (see :func:`~lwrlab.tracking.store.sqlite.absolute_tracking_uri`).
    experiment_id
        The experiment.
    ui_port
        The port ``mlflow ui`` serves a local store on (``mlflow ui --port``).

    Returns
    -------
    str | None
        One line; ``None`` for a store that is neither a server nor local (a database server, Databricks).

    Examples
    --------
    >>> runs_view_hint("http://user:secret@mlflow.lab:5000/", "3")
    'MLflow UI: http://mlflow.lab:5000/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_hint("sqlite:////lab/outputs/mlflow.db", "3")  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: mlflow ui --backend-store-uri sqlite:////lab/outputs/mlflow.db, then open
    http://127.0.0.1:5000/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_hint("sqlite:////lab/mlflow.db", "3", ui_port=5001)  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: mlflow ui --backend-store-uri sqlite:////lab/mlflow.db --port 5001, then open
    http://127.0.0.1:5001/#/experiments/3/runs?workflowType=machine_learning'
    """
    path = runs_view_path(experiment_id)
    if tracking_uri.startswith(("http://", "https://")):
        server = Redactor().redact(without_userinfo(tracking_uri)).rstrip("/")
        return f"MLflow UI: {server}{path}"
    is_folder = "://" not in tracking_uri and ":" not in tracking_uri  # a plain path: a file store
    if sqlite_database_path(tracking_uri) is None and not tracking_uri.startswith("file:") and not is_folder:
        return None
    command = f"mlflow ui --backend-store-uri {shlex.quote(tracking_uri)}"
    if ui_port != MLFLOW_UI_PORT:
        command += f" --port {ui_port}"
    return f"MLflow UI: {command}, then open http://{MLFLOW_UI_HOST}:{ui_port}{path}"


def _experiment_id(client: MlflowClient, name: str) -> str:
    found = retry_locked(client.get_experiment_by_name, name)
    if found is None:
        raise ValueError(f"no experiment named {name!r}")
    return found.experiment_id


def _experiment_of_parent(client: MlflowClient, parent_run_id: str) -> tuple[str, str]:
    parent = retry_locked(client.get_run, parent_run_id)
    experiment = retry_locked(client.get_experiment, parent.info.experiment_id)
    return experiment.experiment_id, experiment.name


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``lwrlab compare`` (the README's commands are parsed with it in the tests)."""
    parser = argparse.ArgumentParser(prog="lwrlab compare", description=__doc__.split("\n\n")[0])
    add_tracking_uri_option(parser)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--experiment", help="experiment name")
    source.add_argument("--parent", metavar="RUN_ID", help="a sweep's parent run: compare its nested runs")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="keep runs with this param; plugin choices by short name (estimator=sdp)",
    )
    parser.add_argument(
        "--tag", action="append", default=[], metavar="KEY=VALUE", help="keep runs with this tag"
    )
    parser.add_argument("--filter", default="", help='extra MLflow filter, e.g. "metrics.rms_mean < 0.5"')
    parser.add_argument(
        "--by",
        action="append",
        default=None,
        metavar="KEY",
        help="group by this param (default: the params the runs differ in)",
    )
    parser.add_argument(
        "--output", type=Path, default=None, help="output folder (default: outputs/compare/<name>_<time>)"
    )
    parser.add_argument("--no-log", action="store_true", help="do not log the comparison as an MLflow run")
    parser.add_argument(
        "--ui-port",
        type=int,
        default=MLFLOW_UI_PORT,
        help=f"port of your `mlflow ui` for the printed link (default {MLFLOW_UI_PORT}, mlflow's)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``lwrlab compare ...``; returns the process exit status."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    uri = absolute_tracking_uri(arguments.tracking_uri, Path.cwd())
    client = MlflowClient(tracking_uri=uri)
    extra = arguments.filter
    try:
        if arguments.parent:
            experiment_id, experiment = _experiment_of_parent(client, arguments.parent)
            nested = f"tags.`mlflow.parentRunId` = '{arguments.parent}'"
            extra = f"{nested} and {extra}" if extra.strip() else nested
        else:
            experiment = arguments.experiment
        filter_string = selection_filter(
            parse_pairs(arguments.tag, "tag"), parse_pairs(arguments.param, "param"), extra
        )
        runs = select_runs(uri, [experiment], filter_string)
        if runs.empty:
            parser.error(f"no FINISHED job run of experiment {experiment!r} matches `{filter_string}`")
        if not arguments.parent:
            experiment_id = _experiment_id(client, experiment)
        comparison = compare_runs(runs, arguments.by)
    except (ValueError, MlflowException, OSError) as error:
        # An unknown experiment, run or parameter, a bad filter, an unreachable store: one line, no traceback.
        parser.error(str(Redactor().redact(str(error))))
    name = arguments.parent or experiment
    stamp = _dt.datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    folder_name = re.sub(r"[^\w.-]", "_", name)
    output = arguments.output or Path("outputs") / "compare" / f"{folder_name}_{stamp}"
    title = f"{experiment}: comparison" + (f" of sweep {arguments.parent}" if arguments.parent else "")
    write_comparison(comparison, output, title)
    print((output / "compare.md").read_text(encoding="utf-8"))
    hint = runs_view_hint(uri, experiment_id, arguments.ui_port)
    if hint is not None:
        print(hint)
    if not arguments.no_log:
        key = derived_key("compare", runs["run_id"], {"filter": filter_string, "by": comparison.groups})
        tags = {
            RUN_KIND_TAG: "compare",
            "source_runs": str(len(runs)),
            "grouped_by": ",".join(comparison.groups),
            "filter": filter_string[:5000],
            **provenance_tags(Path.cwd()),
        }
        run_name = "compare · " + (", ".join(comparison.groups) or ALL_RUNS)
        run_id, logged = log_derived_run(
            client,
            experiment_id,
            key,
            output,
            run_name,
            tags,
            arguments.parent,
            metrics=comparison_metrics(comparison),
            tables={TABLE_ARTIFACT: _json_table(comparison.table.reset_index())},
        )
        said = "logged as" if logged else "already logged as"
        print(f"comparison {said} run {run_id} of experiment {experiment!r}")
    print(f"comparison written to {output}")
    return 0


__all__ = [
    "MLFLOW_UI_ADDRESS",
    "MLFLOW_UI_PORT",
    "TABLE_ARTIFACT",
    "Comparison",
    "compare_runs",
    "comparison_metrics",
    "group_key",
    "headline_metrics",
    "main",
    "per_joint_rms",
    "runs_view_hint",
    "runs_view_path",
    "to_markdown",
    "write_comparison",
]
