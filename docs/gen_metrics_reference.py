"""Write the metric reference from the code that names metrics (run by mkdocs-gen-files).

The headline metrics and their units come from ``lwrlab.tracking.job_config.naming.HEADLINE_METRICS``
(what ``lwrlab compare`` tabulates and each experiment's description lists), the sections MLflow files
metrics under from ``lwrlab.tracking.job_config.metric_sections`` (its rules, tried in order), and every
other metric, its unit and meaning from ``lwrlab.tracking.job_config.metric_catalogue``. Nothing is
typed here.
"""

from __future__ import annotations

import re

import mkdocs_gen_files

from lwrlab.tracking.job_config.metric_catalogue import CATALOGUE
from lwrlab.tracking.job_config.metric_sections import SECTION_RULES, SUMMARY, sectioned_name
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS


def mlflow_key(name: str) -> str:
    """The MLflow key of a family's name: its section found on an example (``<k>`` a joint number)."""
    example = re.sub(r"<[^>]+>", "x", name.replace("<k>", "1"))
    section = sectioned_name(example).removesuffix(example)
    return section + name


def page() -> str:
    lines = [
        "# Metrics and units\n",
        "A task names its metrics plainly (`rms_mean`): that name is the one in its `metrics.json`, in "
        '`lwrlab compare` and in `--filter "metrics.rms_mean < 0.5"`. MLflow files each under a '
        "section chosen by the name's pattern (`accuracy/rms_mean`). Generated from the code at each "
        "build.\n",
        "## Headline metrics\n",
        "| metric | MLflow key | unit | meaning |",
        "|---|---|---|---|",
    ]
    for name, (unit, meaning) in HEADLINE_METRICS.items():
        lines.append(f"| `{name}` | `{sectioned_name(name)}` | {unit} | {meaning} |")
    lines += [
        "",
        "## Sections\n",
        "Tried in this order; the first pattern that matches the plain name wins.\n",
    ]
    lines += ["| section | pattern of the plain name |", "|---|---|"]
    lines += [
        f"| `{section}/` | `{pattern.pattern.replace('|', chr(92) + '|')}` |"
        for section, pattern in SECTION_RULES
    ]
    lines += [
        f"| `{SUMMARY}/` | a sweep's parent run: `jobs`, `finished`, `failed`, `killed`, "
        "`best_<metric>`, `mean_<metric>` |",
        "",
        "Any other metric (a painting's coverage, a tool's mass) keeps its plain name in MLflow's "
        "default section.\n",
        "## Every metric\n",
        "What each task logs, its unit (`1`: a ratio or a count) and the MLflow key it is filed under.\n",
        "| metric | MLflow key | unit | meaning | task |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| `{f.name}` | `{mlflow_key(f.name)}` | {f.unit} | {f.meaning} | {f.task} |" for f in CATALOGUE
    ]
    return "\n".join(lines) + "\n"


with mkdocs_gen_files.open("reference/metrics.md", "w") as out:
    out.write(page())
