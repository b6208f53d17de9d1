"""Write the metric reference from the code that names metrics (run by mkdocs-gen-files).

The headline metrics and their units come from ``lwrlab.tracking.job_config.naming.HEADLINE_METRICS``
(what ``lwrlab compare`` tabulates and each experiment's description lists), the sections MLflow files
metrics under from ``lwrlab.tracking.job_config.metric_sections`` (its rules, tried in order).
"""

from __future__ import annotations

import mkdocs_gen_files

from lwrlab.tracking.job_config.metric_sections import SECTION_RULES, SUMMARY, sectioned_name
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS

OTHERS = {
    "rms_joint<k>, nrms_joint<k>": ("N·m, %", "cross-validation RMS / NRMS of joint k"),
    "fit_rel_error": ("1", "‖τ − τ̂‖/‖τ‖ on the identification logs"),
    "friction_cv_nrms": ("%", "held-out NRMS of the friction law chosen by `friction=auto`"),
    "friction_candidates": ("1", "how many friction candidates were scored"),
    "rotor_inertia_columns": ("1", "1 if the chosen model has reflected rotor-inertia columns"),
    "cond_W_b": ("1", "condition number of the base regressor (column-scaled)"),
    "fit_cpu_s, stage_<name>_s": ("s", "CPU time of the fit, wall time of a stage"),
    "detections, false_alarm_rate, monitored_alarm_rate": (
        "1, 1/h, 1/h",
        "`task=monitor`: contacts found, alarms per hour",
    ),
    "detections_signals_disagree": (
        "1",
        "`task=monitor`: detections where the log's velocities contradict its positions (may be artefacts)",
    ),
    "missed_contacts, false_alarms, median_delay_ms, torque_rms_error": (
        "1, 1, ms, N·m",
        "`task=monitor` against a known truth (simulations)",
    ),
    "recognised_unknown": ("1", "1 if the payload is far from every library tool (open set)"),
}
"""Other metrics the site names, with units (the tasks' own results keep MLflow's default section)."""


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
        "## Other metrics named in this manual\n",
        "| metric | unit | meaning |",
        "|---|---|---|",
    ]
    lines += [f"| `{name}` | {unit} | {meaning} |" for name, (unit, meaning) in OTHERS.items()]
    return "\n".join(lines) + "\n"


with mkdocs_gen_files.open("reference/metrics.md", "w") as out:
    out.write(page())
