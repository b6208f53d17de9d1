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
The table itself is computed in :mod:`lwrlab.tracking.reports.comparison`, the UI's view and its link
in :mod:`lwrlab.tracking.runs.runs_view`; this module selects the runs, writes the folder and logs it.

The folder is logged once as a run of the compared experiment (nested under the sweep's parent when
one is compared), with the table as metrics ``<group>/<metric>`` (``estimator:ols/rms_mean``: the
group's mean; ``<group>/runs``) and as MLflow's table artifact ``compare_table.json``, so that the
comparison run's row in the runs table shows its figures; the same comparison of the same runs is not
logged twice. After the table it saves lwrlab's view of the runs on the experiment (headline metric
columns, sorted best first, grouped by what the runs differ in, the ``accuracy`` charts first) and
prints the link that opens it in MLflow's model-training view in any browser (MLflow 3.17 opens a new
browser on its GenAI view whatever the experiment's kind): the URL for a server, the ``mlflow ui``
command and the URL for a local store, on the port given by ``--ui-port``.

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
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.config_params import RUN_NAME_MAX_LENGTH, truncate
from lwrlab.tracking.job_config.provenance import PARENT_RUN_TAG, RUN_KIND_TAG, provenance_tags
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.reports.compare_html import comparison_page
from lwrlab.tracking.reports.comparison import (
    ALL_RUNS,
    METRIC_PREFIX,
    Comparison,
    _group_labels,
    _json_table,
    _shown_column,
    _unit,
    compare_runs,
    comparison_metrics,
    group_key,
    headline_metrics,
    per_joint_rms,
    to_markdown,
)
from lwrlab.tracking.reports.derived_runs import derived_key, log_derived_run
from lwrlab.tracking.reports.run_groups import PARAM_PREFIX, SEED
from lwrlab.tracking.reports.run_selection import parse_pairs, select_runs, selection_filter
from lwrlab.tracking.runs.run_queries import reused_run_ids, run_id_filter
from lwrlab.tracking.runs.runs_view import (
    MLFLOW_UI_ADDRESS,
    MLFLOW_UI_PORT,
    runs_view_hint,
    runs_view_link,
    runs_view_path,
)
from lwrlab.tracking.store.sqlite import (
    absolute_tracking_uri,
    add_tracking_uri_option,
    retry_locked,
)

log = logging.getLogger(__name__)

TABLE_ARTIFACT = "compare_table.json"
"""The comparison table as MLflow's table artifact (shown as a table in the artifact view)."""


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
            *(f"- NOTE: {note}" for note in comparison.notes),
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
    labels = _group_labels(comparison.runs, comparison.groups)
    joints = per_joint_rms(comparison.runs, labels)
    figures = []
    if joints is not None:
        mean, spread, groups = joints
        shown = dict(zip(labels, _group_labels(comparison.runs, comparison.groups, short=True), strict=True))
        legend = [shown[group] for group in groups]
        figures.append(rms_per_joint_by_group(mean, spread, legend, output_dir / "rms_per_joint.png", title))
    page = comparison_page(
        title,
        comparison.table,
        comparison.metrics,
        {metric: _unit(metric) for metric in comparison.metrics},
        runs_compared.rename(columns=_shown_column),
        figures,
        notes=[
            f"{len(comparison.runs)} FINISHED job runs; grouped by {grouped_by}; seeds pooled as replication",
            *comparison.notes,
        ],
    )
    (output_dir / "compare.html").write_text(page, encoding="utf-8")
    return [*written, *figures, output_dir / "compare.html"]


def _experiment_id(client: MlflowClient, name: str) -> str:
    found = retry_locked(client.get_experiment_by_name, name)
    if found is None:
        raise ValueError(f"no experiment named {name!r}")
    return found.experiment_id


def _experiment_of_parent(client: MlflowClient, parent_run_id: str) -> tuple[str, str]:
    parent = retry_locked(client.get_run, parent_run_id)
    experiment = retry_locked(client.get_experiment, parent.info.experiment_id)
    return experiment.experiment_id, experiment.name


def sweep_runs(
    client: MlflowClient, tracking_uri: str, experiment: str, parent_run_id: str, filter_string: str
) -> pd.DataFrame:
    """The runs of ``experiment`` matching ``filter_string`` that are jobs of the sweep ``parent_run_id``:
    those nested under it and those it reused (jobs whose config had already finished elsewhere)."""
    parent = retry_locked(client.get_run, parent_run_id)
    reused = reused_run_ids(parent)
    selections = [f"tags.`{PARENT_RUN_TAG}` = '{parent_run_id}'"]
    selections += [run_id_filter(reused[start : start + 100]) for start in range(0, len(reused), 100)]
    tables = [select_runs(tracking_uri, [experiment], f"{filter_string} and {s}") for s in selections]
    found = [table for table in tables if not table.empty]
    if not found:
        return pd.DataFrame()
    return pd.concat(found, ignore_index=True).drop_duplicates("run_id", ignore_index=True)


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
    try:
        filter_string = selection_filter(
            parse_pairs(arguments.tag, "tag"), parse_pairs(arguments.param, "param"), arguments.filter
        )
        if arguments.parent:
            experiment_id, experiment = _experiment_of_parent(client, arguments.parent)
            runs = sweep_runs(client, uri, experiment, arguments.parent, filter_string)
        else:
            experiment = arguments.experiment
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
    compared = comparison.runs
    metrics = [
        name[len(METRIC_PREFIX) :] for name in map(str, compared.columns) if name.startswith(METRIC_PREFIX)
    ]
    seeds = compared[PARAM_PREFIX + SEED].nunique() if PARAM_PREFIX + SEED in compared else 0
    shown = [SEED] if seeds > 1 else []  # replication: a column, not a group
    hint = runs_view_link(client, uri, experiment_id, metrics, comparison.groups, shown, arguments.ui_port)
    if hint is not None:
        print(hint)
    if not arguments.no_log:
        key = derived_key("compare", runs["run_id"], {"filter": filter_string, "by": comparison.groups})
        tags = {
            RUN_KIND_TAG: "compare",
            "source_runs": str(len(runs)),
            "grouped_by": ",".join(comparison.groups)[:5000],
            "filter": filter_string[:5000],
            **provenance_tags(Path.cwd()),
        }
        run_name = truncate("compare · " + (", ".join(comparison.groups) or ALL_RUNS), RUN_NAME_MAX_LENGTH)
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
