"""Settings checked where the job starts: a wrong type or range fails at once, naming the key.

Hydra composes what the user typed (``seed=1.5``, ``plant.torque_noise_std=abc``) without knowing what
a value means; the plugins would fail much later, with a numpy error that names no key, or not at
all (a negative noise level is squared away). :data:`RULES` says, per key, what a value must be; a
key the composed config does not hold (another plant, another task) is not checked. Every
violation is listed in one :class:`~lwrlab.errors.ConfigError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from lwrlab.errors import ConfigError

_MISSING = object()


@dataclass(frozen=True)
class Rule:
    """What the value at ``key`` must be."""

    key: str
    """Dotted config key."""
    accepts: Callable[[Any], bool]
    """True for an acceptable value."""
    expected: str
    """What an acceptable value is, in words."""


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _numbers(value: Any) -> list[Any]:
    """A scalar or a list of numbers (per-joint settings) as a list."""
    return list(value) if isinstance(value, list | tuple) else [value]


def non_negative(key: str, per_joint: bool = False) -> Rule:
    """A number ≥ 0 (or a list of them, per joint)."""
    return Rule(
        key,
        lambda v: all(_number(x) and x >= 0 for x in (_numbers(v) if per_joint else [v])),
        "a number ≥ 0" + (" (or one per joint)" if per_joint else ""),
    )


def positive(key: str, nullable: bool = False) -> Rule:
    """A number > 0 (or null)."""
    return Rule(
        key,
        lambda v: (nullable and v is None) or (_number(v) and v > 0),
        "a number > 0" + (" or null" if nullable else ""),
    )


def one_of(key: str, *choices: Any) -> Rule:
    """One of ``choices``."""
    return Rule(key, lambda v: v in choices, f"one of {list(choices)}")


RULES: tuple[Rule, ...] = (
    Rule("seed", lambda v: _integer(v) and v >= 0, "an integer ≥ 0"),
    non_negative("plant.torque_noise_std", per_joint=True),
    non_negative("plant.encoder_noise_std", per_joint=True),
    non_negative("plant.encoder_resolution"),
    non_negative("plant.parameter_spread"),
    non_negative("plant.friction_spread"),
    Rule("plant.substeps", lambda v: _integer(v) and v >= 1, "an integer ≥ 1"),
    positive("trajectory.duration"),
    positive("validation.duration"),
    positive("measurement.rate_hz"),
    Rule(
        "measurement.processing.cutoff_hz",
        lambda v: v is None or v == "auto" or (_number(v) and v > 0),
        "a number > 0 (Hz), auto or null",
    ),
    Rule("measurement.processing.order", lambda v: _integer(v) and 1 <= v <= 12, "an integer in [1, 12]"),
    one_of("measurement.processing.difference_accuracy", 2, 4),
    Rule(
        "measurement.processing.trim_s",
        lambda v: v is None or (_number(v) and v >= 0),
        "a number ≥ 0 (s) or null",
    ),
    positive("measurement.processing.rate_hz", nullable=True),
    one_of("measurement.processing.velocity", "auto", "logged", "differentiated"),
    Rule("data.validation_fraction", lambda v: _number(v) and 0 < v < 1, "a number in (0, 1)"),
    one_of("data.time_unit", "s", "ms", "us", "ns"),
    one_of("data.position_unit", "rad", "deg"),
    positive("data.rate_hz", nullable=True),
    Rule("data.min_samples", lambda v: _integer(v) and v >= 2, "an integer ≥ 2"),
    Rule(
        "data.drive_gains",
        lambda v: v is None or (isinstance(v, list | tuple) and all(_number(x) and x != 0 for x in v)),
        "null or a list of non-zero numbers (N·m/A per joint)",
    ),
    Rule("statistics.resamples", lambda v: _integer(v) and v >= 0, "an integer ≥ 0"),
    positive("statistics.block_s"),
    Rule("statistics.confidence", lambda v: _number(v) and 0 < v < 1, "a number in (0, 1)"),
)
"""The settings checked, by key."""


def _plain(value: Any) -> Any:
    from omegaconf import DictConfig, ListConfig, OmegaConf

    return (
        OmegaConf.to_container(value, resolve=True) if isinstance(value, DictConfig | ListConfig) else value
    )


def violations(cfg: Any, rules: Iterable[Rule] = RULES) -> list[str]:
    """One line per rule that a value of ``cfg`` (a composed Hydra config) breaks."""
    from omegaconf import OmegaConf

    problems = []
    for rule in rules:
        value = OmegaConf.select(cfg, rule.key, default=_MISSING, throw_on_missing=False)
        if value is _MISSING or OmegaConf.is_missing(cfg, rule.key):
            continue
        value = _plain(value)
        if not rule.accepts(value):
            problems.append(f"{rule.key}={value!r}: must be {rule.expected}")
    return problems


def check_config(cfg: Any, rules: Iterable[Rule] = RULES) -> None:
    """Raise :class:`ConfigError` listing every setting of ``cfg`` that breaks its rule."""
    problems = violations(cfg, rules)
    if problems:
        raise ConfigError("invalid settings:\n  " + "\n  ".join(problems))
