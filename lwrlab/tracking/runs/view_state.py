"""What MLflow's runs page shows when opened from lwrlab's link, in the form MLflow's UI stores a view.

MLflow's UI keeps the runs page's columns, sort and grouping in the browser's local storage, so a new
browser starts on its defaults (Dataset, Duration, Source, Models: no metric). A view saved on the
experiment (the UI's *Save view* button, or :mod:`lwrlab.tracking.runs.runs_view`) opens the same in
any browser. This module builds such a view and its stored text; it reads and writes no store.

The view (:func:`runs_view_state`):

* columns, in this order and wide enough for a metric's first digits: the swept parameters (and the
  seed where runs differ in it), the headline metrics present in their order (``accuracy/rms_mean``
  [N·m], ``accuracy/nrms_mean`` [%], ``accuracy/validation_rel_error``,
  ``accuracy/base_parameter_error``), ``summary/best_<first headline metric>`` for a sweep's row,
  then Dataset (what each run was fitted on) and Models where the experiment has logged models. The
  grid draws only the columns in sight: in a window 1400 pixels wide the headline metrics are in
  sight, Dataset and Models a scroll away;
* sorted by the first headline metric present, smallest first (every headline metric is an error);
* grouped by the swept parameters, a group's row showing its runs' average as ``lwrlab compare``
  does, every group open (runs that lack the parameters, such as a sweep's parent run and the
  comparison run, in an open group of their own); nothing swept: grouped by ``run_kind`` (job,
  sweep, compare). Grouping also lays a sweep's jobs out without opening its parent run: MLflow
  3.17 drops a saved view's opened rows (``runsExpanded``) when it loads one;
* charts: the ``accuracy`` section first, its charts in the headline order; MLflow's UI adds the
  charts of the other metrics in their sections (alphabetical, its ``Model metrics`` and
  ``System metrics`` last).

The stored text (:func:`encode_view`, as MLflow 3.17's UI writes it; :func:`decode_view` reads it
back) is the JSON envelope ``{"name", "createdAt", "updatedAt", "state"}`` (times in ms since the
epoch) whose ``state`` is the page state as JSON, deflated (zlib) and base64-encoded behind
``deflate;``. :func:`decode_view` also reads a bare state, deflated or plain JSON, as older UIs wrote.

Examples
--------
>>> state = runs_view_state(["rms_mean", "nrms_mean", "rms_joint1"], ["estimator"])
>>> state["orderByKey"], state["orderByAsc"]
('metrics.`accuracy/rms_mean`', True)
>>> for name in state["selectedColumns"]:
...     print(name)
params.`estimator`
metrics.`accuracy/rms_mean`
metrics.`accuracy/nrms_mean`
metrics.`summary/best_rms_mean`
attributes.`Dataset`
>>> saved = decode_view(encode_view(SavedView("lwrlab · runs by estimator", state, 0, 0)))
>>> saved.state == state and saved.name == "lwrlab · runs by estimator"
True
"""

from __future__ import annotations

import base64
import hashlib
import json
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from lwrlab.tracking.job_config.metric_sections import (
    ACCURACY,
    SUMMARY,
    metric_section,
    plain_name,
    sectioned_name,
)
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS
from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG

DEFLATE_PREFIX = "deflate;"
"""What a deflated, base64-encoded state starts with (MLflow's ``textCompressDeflate``)."""
MODEL_METRICS_SECTION = "Model metrics"
"""MLflow's chart section of metrics without a ``<section>/`` prefix."""
SYSTEM_METRICS_SECTION = "System metrics"
GROUP_AGGREGATE = "average"
"""What a group's row shows of its runs' metrics (``lwrlab compare`` shows the mean too)."""
CHART_RUNS = 10
"""Runs (or groups) a chart shows, MLflow's default."""


@dataclass(frozen=True)
class SavedView:
    """A view of the runs page as the experiment's tag holds it."""

    name: str
    """Shown in the UI's list of saved views."""
    state: dict[str, Any]
    """The page state: search facets (``orderByKey``, …) and UI state (``selectedColumns``, …)."""
    created_ms: int
    updated_ms: int


def column(kind: str, name: str) -> str:
    """A column's key in the page state: ``kind`` is ``attributes``, ``params``, ``metrics`` or ``tags``.

    Examples
    --------
    >>> column("metrics", "accuracy/rms_mean")
    'metrics.`accuracy/rms_mean`'
    """
    return f"{kind}.`{name}`"


def is_replication(key: str) -> bool:
    """Whether a parameter repeats an experiment rather than changing it (``seed``, ``trajectory.seed``).

    Examples
    --------
    >>> is_replication("seed"), is_replication("trajectory.seed"), is_replication("estimator")
    (True, True, False)
    """
    return key.rsplit(".", 1)[-1] == "seed"


def _grouping(grouped_by: Sequence[str]) -> tuple[dict[str, Any], dict[str, bool]]:
    """MLflow's ``groupBy`` for the keys (by ``run_kind`` without any) and every group opened."""
    keys = [("param", key) for key in grouped_by] or [("tag", RUN_KIND_TAG)]
    group_by = {
        "aggregateFunction": GROUP_AGGREGATE,
        "groupByKeys": [{"mode": mode, "groupByData": key} for mode, key in keys],
    }
    # Groups of values are open unless closed; the group of runs without any value only if opened.
    remaining_group = ",".join(f"{mode}.{key}" for mode, key in keys)
    return group_by, {remaining_group: True}


def _width(name: str) -> int:
    """Pixels: a metric's first digits, a parameter's value, a dataset's name and digest."""
    return 200 if name.startswith("attributes") else 100 if name.startswith("params") else 140


def _uuid(kind: str, name: str) -> str:
    """A stable id for a chart or a section: the same view gives the same text."""
    return f"lwrlab{kind}{hashlib.sha256(name.encode()).hexdigest()[:16]}"


def _charts(metrics: set[str]) -> dict[str, Any]:
    """The ``accuracy`` section first with its charts, headline metrics first; ``{}`` without any."""
    in_section = [metric for metric in metrics if metric_section(metric) == ACCURACY]
    ordered = [metric for metric in HEADLINE_METRICS if metric in in_section]
    ordered += sorted(metric for metric in in_section if metric not in ordered)
    if not ordered:
        return {}
    sections = [ACCURACY, MODEL_METRICS_SECTION, SYSTEM_METRICS_SECTION]  # the UI keeps its own two last
    charts = [
        {
            "uuid": _uuid("chart", sectioned_name(metric)),
            "type": "BAR",
            "runsCountToCompare": CHART_RUNS,
            "metricSectionId": _uuid("section", ACCURACY),
            "deleted": False,
            "isGenerated": True,
            "metricKey": sectioned_name(metric),
        }
        for metric in ordered
    ]
    return {
        "compareRunCharts": charts,
        "compareRunSections": [
            {
                "uuid": _uuid("section", name),
                "name": name,
                "display": True,
                "isReordered": False,
                "deleted": False,
                "isGenerated": True,
            }
            for name in sections
        ],
        "isAccordionReordered": False,  # the UI sorts the sections it adds: `accuracy` stays first
    }


def runs_view_state(
    metrics: Iterable[str],
    grouped_by: Sequence[str],
    shown_params: Sequence[str] = (),
    models: bool = False,
) -> dict[str, Any]:
    """The runs page's state: headline columns, sorted best first, grouped by what was swept.

    Parameters
    ----------
    metrics
        The metrics the runs logged, plain (``rms_mean``) or as MLflow keys (``accuracy/rms_mean``).
    grouped_by
        The parameters the runs differ in (``estimator``): columns and groups (a seed only a column).
    shown_params
        Further parameter columns (``seed``, where runs differ in it).
    models
        Show the Models column (the experiment has logged models).

    Returns
    -------
    dict
        The fields MLflow's UI reads from a saved view (``orderByKey``, ``selectedColumns``,
        ``groupBy``, ``groupsExpanded``, ``compareRunCharts``, …); see the module's docstring.
    """
    plain = {plain_name(metric) for metric in metrics}
    headline = [metric for metric in HEADLINE_METRICS if metric in plain]
    params = list(dict.fromkeys([*grouped_by, *shown_params]))
    columns = [column("params", key) for key in params]
    columns += [column("metrics", sectioned_name(metric)) for metric in headline]
    if headline:
        columns.append(column("metrics", f"{SUMMARY}/best_{headline[0]}"))
    columns.append(column("attributes", "Dataset"))
    columns += [column("attributes", "Models")] if models else []
    group_by, groups_expanded = _grouping([key for key in grouped_by if not is_replication(key)])
    state: dict[str, Any] = {
        "selectedColumns": columns,
        "columnOrder": columns,
        "columnWidths": {name: _width(name) for name in columns},
        "groupBy": group_by,
        "groupsExpanded": groups_expanded,
    }
    if headline:
        state.update(orderByKey=column("metrics", sectioned_name(headline[0])), orderByAsc=True)
    state.update(_charts(plain))
    return state


def _deflate(text: str) -> str:
    return DEFLATE_PREFIX + base64.b64encode(zlib.compress(text.encode("utf-8"))).decode("ascii")


def _inflate(text: str) -> str:
    return zlib.decompress(base64.b64decode(text[len(DEFLATE_PREFIX) :])).decode("utf-8")


def encode_view(view: SavedView) -> str:
    """The tag value of a saved view, as MLflow 3.17's UI writes it (see the module's docstring)."""
    state = json.dumps(view.state, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    envelope = {
        "name": view.name,
        "createdAt": view.created_ms,
        "updatedAt": view.updated_ms,
        "state": _deflate(state),
    }
    return json.dumps(envelope, separators=(",", ":"), ensure_ascii=False)


def decode_view(value: str) -> SavedView:
    """A saved view from its tag value: an envelope, or a bare state (deflated or JSON) named ``""``.

    Raises
    ------
    ValueError
        The value is none of these.
    """
    try:
        envelope = json.loads(value) if not value.startswith(DEFLATE_PREFIX) else None
    except json.JSONDecodeError as error:
        raise ValueError(f"not a saved view: {error}") from error
    if isinstance(envelope, dict) and isinstance(envelope.get("state"), str) and "name" in envelope:
        created = int(envelope.get("createdAt", 0))
        updated = int(envelope.get("updatedAt", created))
        name, text = str(envelope["name"]), envelope["state"]
    else:
        name, text, created, updated = "", value, 0, 0
    try:
        state = json.loads(_inflate(text) if text.startswith(DEFLATE_PREFIX) else text)
    except (ValueError, zlib.error) as error:  # bad base64, deflate or JSON
        raise ValueError(f"not a saved view's state: {error}") from error
    if not isinstance(state, dict):
        raise ValueError("not a saved view's state: not a JSON object")
    return SavedView(name, state, created, updated)


__all__ = [
    "DEFLATE_PREFIX",
    "GROUP_AGGREGATE",
    "MODEL_METRICS_SECTION",
    "SYSTEM_METRICS_SECTION",
    "SavedView",
    "column",
    "decode_view",
    "encode_view",
    "is_replication",
    "runs_view_state",
]
