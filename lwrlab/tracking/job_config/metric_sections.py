"""Where each metric is filed in MLflow: ``<section>/<name>``, so that MLflow's chart view groups them.

A task names its metrics plainly (``rms_mean``, ``rms_joint3``, ``fit_cpu_s``): that name is the one in
its ``metrics.json``, in ``lwrlab compare`` and in the code. Only MLflow sees a section in front, chosen
by the name's pattern, not from a list, so that a metric added later lands in the right section:

=============== ======================================================================== ===========
section         what (pattern of the plain name)                                          example
=============== ======================================================================== ===========
``accuracy``    torque and parameter errors: ``(n)rms_mean``, ``*rel_error*``,           ``rms_mean``
                ``*parameter_error``, ``*_rms_error*`` (sorts first in the chart view)
``diagnostics`` conditioning, identifiability, priors, uncertainty calibration, sizes    ``cond_W_b``
``joints``      one value per joint: ``*_joint<k>``, ``*_j<k>``, list items ``*.<k>``     ``rms_joint3``
``timing``      durations in seconds: ``*_cpu_s``, ``*_wall_s``, ``stage_*_s``, …         ``fit_cpu_s``
=============== ======================================================================== ===========

Any other metric (a painting's painted area, a tool's mass) is a task's own result: it keeps its plain
name, which MLflow shows in its default *Model metrics* section. Runs logged before sections existed
have plain names only; :func:`plain_name` reads both, so ``lwrlab compare`` and ``lwrlab report`` read
old and new runs alike.

Examples
--------
>>> sectioned_name("rms_mean"), sectioned_name("rms_joint3"), sectioned_name("cond_W_b")
('accuracy/rms_mean', 'joints/rms_joint3', 'diagnostics/cond_W_b')
>>> sectioned_name("fit_cpu_s"), sectioned_name("painted_fraction")
('timing/fit_cpu_s', 'painted_fraction')
>>> plain_name("accuracy/rms_mean"), plain_name("rms_mean"), plain_name("estimator:ols/rms_mean")
('rms_mean', 'rms_mean', 'estimator:ols/rms_mean')
"""

from __future__ import annotations

import re
from collections.abc import Mapping

ACCURACY = "accuracy"
"""The headline section: its name sorts before the others in MLflow's chart view."""
DIAGNOSTICS = "diagnostics"
JOINTS = "joints"
TIMING = "timing"
SUMMARY = "summary"
"""The section of a sweep's parent run's metrics (best and mean of the headline metrics, job counts)."""

_TIMING = re.compile(r"(_cpu_s|_wall_s|_time_s)$|^stage_\w+_s$|^(optimisation|identification|simulation)_s$")
_JOINTS = re.compile(r"(_joint\d+|_j\d+|\.\d+)$")
_ACCURACY = re.compile(r"^n?rms_mean$|rel_error|parameter_error$|_rms_error")
_DIAGNOSTICS = re.compile(
    r"^(cond|identifiability|n_|residual|prior_|still_joints|smallest_|min_pseudo)|_coverage$|_eigenvalue$"
)

SECTION_RULES: tuple[tuple[str, re.Pattern[str]], ...] = (
    (TIMING, _TIMING),
    (JOINTS, _JOINTS),
    (ACCURACY, _ACCURACY),
    (DIAGNOSTICS, _DIAGNOSTICS),
)
"""(section, pattern) in the order they are tried: the first whose pattern matches the plain name wins
(``rms_joint3`` is a joint's figure before it is an error; ``fit_cpu_s`` a duration)."""

SECTIONS = frozenset({section for section, _ in SECTION_RULES} | {SUMMARY})


def metric_section(name: str) -> str | None:
    """The section a plain metric name is filed under in MLflow; ``None``: MLflow's default section."""
    for section, pattern in SECTION_RULES:
        if pattern.search(name):
            return section
    return None


def sectioned_name(name: str) -> str:
    """The MLflow key of a plain metric name: ``<section>/<name>``, or the name if it has no section."""
    section = metric_section(name)
    return name if section is None else f"{section}/{name}"


def plain_name(key: str) -> str:
    """The plain name of an MLflow metric key: the section, if one of lwrlab's, taken off."""
    section, separator, name = key.partition("/")
    return name if separator and section in SECTIONS else key


def sectioned_metrics(metrics: Mapping[str, float]) -> dict[str, float]:
    """``metrics`` with MLflow keys (see :func:`sectioned_name`)."""
    return {sectioned_name(name): value for name, value in metrics.items()}


def plain_metrics(metrics: Mapping[str, float]) -> dict[str, float]:
    """``metrics`` read back from MLflow with plain names (see :func:`plain_name`)."""
    return {plain_name(key): value for key, value in metrics.items()}


_FILTERED_METRIC = re.compile(r"\bmetrics\.(`?)([A-Za-z_][\w.]*)\1")


def sectioned_filter(filter_string: str) -> str:
    """An MLflow filter with plain metric names (``metrics.rms_mean < 0.5``) turned into MLflow keys.

    Examples
    --------
    >>> sectioned_filter("metrics.rms_mean < 0.5 and metrics.`painted_fraction` > 0.9")
    'metrics.`accuracy/rms_mean` < 0.5 and metrics.`painted_fraction` > 0.9'
    """

    def replace(match: re.Match[str]) -> str:
        key = sectioned_name(match.group(2))
        return match.group(0) if key == match.group(2) else f"metrics.`{key}`"

    return _FILTERED_METRIC.sub(replace, filter_string)


__all__ = [
    "ACCURACY",
    "DIAGNOSTICS",
    "JOINTS",
    "SECTIONS",
    "SECTION_RULES",
    "SUMMARY",
    "TIMING",
    "metric_section",
    "plain_metrics",
    "plain_name",
    "sectioned_filter",
    "sectioned_metrics",
    "sectioned_name",
]
