"""``compare.html``: the comparison as one self-contained page, for MLflow's artifact viewer or a browser.

One file, nothing fetched: the group table (a click on a column header sorts by it; numbers sort as
numbers, by their mean), the runs compared, and the figures inline as base64 PNG. It opens in MLflow's
artifact view of the comparison run (which shows HTML artifacts in a frame) and in any browser from
``outputs/compare/…``.

Examples
--------
>>> table = pd.DataFrame({"runs": [2], "rms_mean": [0.1], "rms_mean_std": [0.01]}, index=["estimator=ols"])
>>> page = comparison_page("demo", table, ["rms_mean"], {"rms_mean": "N·m"}, pd.DataFrame(), [])
>>> page.startswith("<!DOCTYPE html>") and "0.1 ± 0.01" in page and 'data-value="0.1"' in page
True
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #1f2328; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 14px; }
th, td { border: 1px solid #d0d7de; padding: 4px 10px; text-align: right; }
th { background: #f6f8fa; cursor: pointer; user-select: none; }
th:first-child, td:first-child { text-align: left; }
th[data-order="asc"]::after { content: " ▲"; } th[data-order="desc"]::after { content: " ▼"; }
img { max-width: 100%; border: 1px solid #d0d7de; }
"""

_SORT_SCRIPT = """
document.querySelectorAll("table.sortable").forEach(function (table) {
  table.querySelectorAll("th").forEach(function (header, column) {
    header.addEventListener("click", function () {
      var ascending = header.dataset.order !== "asc";
      table.querySelectorAll("th").forEach(function (other) { delete other.dataset.order; });
      header.dataset.order = ascending ? "asc" : "desc";
      var body = table.tBodies[0];
      var rows = Array.from(body.rows);
      var key = function (row) {
        var cell = row.cells[column];
        var value = cell.dataset.value !== undefined ? parseFloat(cell.dataset.value) : NaN;
        return isNaN(value) ? cell.textContent : value;
      };
      rows.sort(function (a, b) {
        var x = key(a), y = key(b);
        var numbers = typeof x === "number" && typeof y === "number";
        var order = numbers ? x - y : String(x).localeCompare(String(y));
        return ascending ? order : -order;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
});
"""


def _number_cell(mean: float, spread: float = math.nan) -> str:
    if math.isnan(mean):
        return "<td>–</td>"
    text = f"{mean:.4g}" if math.isnan(spread) else f"{mean:.4g} ± {spread:.2g}"
    return f'<td data-value="{mean!r}">{html.escape(text)}</td>'


def _cell(value: object) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return _number_cell(float(value))
    return f"<td>{html.escape(str(value))}</td>"


def group_table_html(table: pd.DataFrame, metrics: Sequence[str], units: Mapping[str, str]) -> str:
    """The group table: one row per group, ``mean ± std`` per metric (sortable by its mean)."""
    plain = [column for column in table.columns if column not in metrics and not column.endswith("_std")]
    headers = [
        "group",
        *plain,
        *(f"{metric} [{units[metric]}]" if units.get(metric) else metric for metric in metrics),
    ]
    rows = []
    for label, row in table.iterrows():
        cells = [_cell(label), *(_cell(row[column]) for column in plain)]
        for metric in metrics:
            spread = row.get(f"{metric}_std", math.nan)
            cells.append(_number_cell(float(row[metric]), float(spread) if pd.notna(spread) else math.nan))
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return _table(headers, rows)


def runs_table_html(runs: pd.DataFrame) -> str:
    """The runs compared, one row each, as they are in ``runs.csv``."""
    if runs.empty:
        return "<p>no runs</p>"
    rows = ["<tr>" + "".join(_cell(value) for value in row) + "</tr>" for row in runs.itertuples(index=False)]
    return _table([str(column) for column in runs.columns], rows)


def _table(headers: Sequence[str], rows: Sequence[str]) -> str:
    head = "".join(f"<th>{html.escape(header)}</th>" for header in headers)
    return f'<table class="sortable"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table>'


def inline_png(path: Path) -> str:
    """An ``<img>`` holding the PNG at ``path`` as a base64 data URI."""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{html.escape(path.stem)}" src="data:image/png;base64,{data}">'


def comparison_page(
    title: str,
    table: pd.DataFrame,
    metrics: Sequence[str],
    units: Mapping[str, str],
    runs: pd.DataFrame,
    figures: Sequence[Path],
    notes: Sequence[str] = (),
) -> str:
    """The whole page: title, notes, the group table, the figures, the runs compared."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        *(f"<p>{html.escape(note)}</p>" for note in notes),
        "<h2>Groups</h2>",
        group_table_html(table, metrics, units),
        *(["<h2>Figures</h2>"] if figures else []),
        *(
            f"<figure>{inline_png(path)}<figcaption>{html.escape(path.name)}</figcaption></figure>"
            for path in figures
        ),
        "<h2>Runs</h2>",
        runs_table_html(runs),
        f"<script>{_SORT_SCRIPT}</script>",
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"


__all__ = ["comparison_page", "group_table_html", "inline_png", "runs_table_html"]
