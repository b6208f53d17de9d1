"""Settings checked where the job starts: a value out of range fails at once, naming the key.

Types and key names are checked earlier, when Hydra composes, by the schemas of :mod:`lwrlab.config`
(``plant.parameter_spread=abc`` or a misspelt key in a YAML never reaches this module). What a type
cannot say is here: :data:`RULES` says, per key, what a value must be (a noise level ≥ 0, a
duration > 0, a cut-off below the Nyquist frequency); a key the composed config does not hold
(another plant, another task) is not checked, and a value copied from another checked key
(``plant.seed: ${seed}``) is reported once, at the key it comes from. :func:`unknown_keys` catches
the keys ``+key=value`` slipped into a typed node (Hydra adds those whatever the schema). Every
violation is listed in one :class:`~lwrlab.errors.ConfigError`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from lwrlab.errors import ConfigError
from lwrlab.pipeline.config_nodes import plain

_MISSING = object()
VELOCITY_SOURCES = ("auto", "logged", "differentiated")
"""Where velocities come from (``measurement.processing.velocity``, ``data.velocity``)."""


@dataclass(frozen=True)
class Rule:
    """What the value at ``key`` must be, alone or given the rest of the config."""

    key: str
    """Dotted config key."""
    accepts: Callable[[Any, Any], bool]
    """True for an acceptable value: ``accepts(value, cfg)``."""
    expected: Callable[[Any], str]
    """What an acceptable value is, in words: ``expected(cfg)``."""


def rule(key: str, accepts: Callable[[Any], bool], expected: str) -> Rule:
    """A rule on the value alone."""
    return Rule(key, lambda value, cfg: accepts(value), lambda cfg: expected)


_SCHEMA_COLUMN = re.compile(r"^(t|(q|dq|tau|current)([1-9][0-9]*)?)$")
"""A name of the log schema (:mod:`lwrlab.io.logs`): what ``data.column_map`` maps from."""


def _one_path(value: Any) -> bool:
    return value is None or isinstance(value, str)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _positive(value: Any) -> bool:
    return _number(value) and value > 0


def _numbers(value: Any) -> list[Any]:
    """A scalar or a list of numbers (per-joint settings) as a list."""
    return list(value) if isinstance(value, list | tuple) else [value]


def non_negative(key: str, per_joint: bool = False) -> Rule:
    """A number ≥ 0 (or a list of them, per joint)."""
    return rule(
        key,
        lambda v: all(_number(x) and x >= 0 for x in (_numbers(v) if per_joint else [v])),
        "a number ≥ 0" + (" (or one per joint)" if per_joint else ""),
    )


def positive(key: str, nullable: bool = False) -> Rule:
    """A number > 0 (or null)."""
    return rule(
        key,
        lambda v: (nullable and v is None) or (_number(v) and v > 0),
        "a number > 0" + (" or null" if nullable else ""),
    )


def positive_list(key: str, what: str, nullable: bool = False) -> Rule:
    """A non-empty list of numbers > 0 (or null)."""
    return rule(
        key,
        lambda v: (
            (nullable and v is None) or (isinstance(v, list) and bool(v) and all(_positive(x) for x in v))
        ),
        f"{'null or ' if nullable else ''}a non-empty list of numbers > 0 ({what})",
    )


def integer_at_least(key: str, minimum: int) -> Rule:
    """An integer ≥ ``minimum``."""
    return rule(key, lambda v: _integer(v) and v >= minimum, f"an integer ≥ {minimum}")


def fraction(key: str) -> Rule:
    """A number in the open interval (0, 1)."""
    return rule(key, lambda v: _number(v) and 0 < v < 1, "a number in (0, 1)")


def one_of(key: str, *choices: Any) -> Rule:
    """One of ``choices``."""
    return rule(key, lambda v: v in choices, f"one of {list(choices)}")


def _reads_logs(cfg: Any) -> bool:
    """Whether the job reads recorded logs (``plant=log`` adds ``data``): their rate is the files'."""
    from omegaconf import OmegaConf

    return OmegaConf.select(cfg, "data", default=None) is not None


def _below_nyquist(cutoff: Any, cfg: Any) -> bool:
    from omegaconf import OmegaConf

    rate = OmegaConf.select(cfg, "measurement.rate_hz", default=None)
    return not (_number(cutoff) and _number(rate)) or _reads_logs(cfg) or cutoff < rate / 2


def _noise_presets(cfg: Any) -> list[str]:
    from omegaconf import OmegaConf

    return sorted(OmegaConf.select(cfg, "task.noise_presets", default=None) or {})


def painting_rules(prefix: str) -> tuple[Rule, ...]:
    """The painting stage's ranges, under ``task.`` (``task=painting``) or ``task.painting.`` (the chain)."""
    return (
        rule(f"{prefix}n_steps", lambda v: all(_integer(n) and n >= 1 for n in v.values()), "integers ≥ 1"),
        positive(f"{prefix}wall.width"),
        positive(f"{prefix}wall.height"),
        positive(f"{prefix}path.rate_hz"),
        positive(f"{prefix}path.search_rate_hz"),
        positive_list(f"{prefix}path.duration_bounds", "s"),
        positive(f"{prefix}path.min_stroke"),
        non_negative(f"{prefix}path.stripe_overlap"),
        non_negative(f"{prefix}contact.approach_s"),
        positive(f"{prefix}contact.duration_scale"),
        positive(f"{prefix}contact.max_duration", nullable=True),
        integer_at_least(f"{prefix}contact.substeps", 1),
        non_negative(f"{prefix}contact.friction"),
        positive(f"{prefix}contact.contact_time_constant"),
        positive(f"{prefix}contact.contact_radius"),
        non_negative(f"{prefix}contact.torque_noise_std", per_joint=True),
        non_negative(f"{prefix}contact.encoder_noise_std", per_joint=True),
        non_negative(f"{prefix}contact.force_noise_std"),
        positive(f"{prefix}estimator.velocity_cutoff_hz"),
        positive(f"{prefix}estimator.acceleration_cutoff_hz"),
        positive(f"{prefix}estimator.wrench_cutoff_hz"),
        positive(f"{prefix}estimator.coulomb_smoothing"),
    )


RULES: tuple[Rule, ...] = (
    integer_at_least("seed", 0),
    # plant=simulated
    one_of("plant.mode", "playback", "closed_loop"),
    non_negative("plant.torque_noise_std", per_joint=True),
    non_negative("plant.encoder_noise_std", per_joint=True),
    non_negative("plant.encoder_resolution"),
    non_negative("plant.parameter_spread"),
    non_negative("plant.friction_spread"),
    integer_at_least("plant.seed", 0),
    positive_list("plant.kp", "N·m/rad per joint", nullable=True),
    positive_list("plant.kd", "N·m·s/rad per joint", nullable=True),
    integer_at_least("plant.substeps", 1),
    # motions
    positive("trajectory.duration"),
    positive("validation.duration"),
    # measurement
    positive("measurement.rate_hz"),
    rule(
        "measurement.processing.cutoff_hz",
        lambda v: v is None or v == "auto" or (_number(v) and v > 0),
        "a number > 0 (Hz), auto or null",
    ),
    Rule(  # a log's rate is known when it is read: lwrlab.signal.processing checks the cut-off there
        "measurement.processing.cutoff_hz",
        _below_nyquist,
        lambda cfg: "below the Nyquist frequency of the simulated sensors, measurement.rate_hz / 2",
    ),
    rule(
        "measurement.processing.state_cutoff_hz",
        lambda v: v is None or v == "auto" or (_number(v) and v > 0),
        "a number > 0 (Hz), auto or null",
    ),
    Rule(
        "measurement.processing.state_cutoff_hz",
        _below_nyquist,
        lambda cfg: "below the Nyquist frequency of the simulated sensors, measurement.rate_hz / 2",
    ),
    rule("measurement.processing.order", lambda v: _integer(v) and 1 <= v <= 12, "an integer in [1, 12]"),
    one_of("measurement.processing.difference_accuracy", 2, 4),
    rule(
        "measurement.processing.trim_s",
        lambda v: v is None or (_number(v) and v >= 0),
        "a number ≥ 0 (s) or null",
    ),
    positive("measurement.processing.rate_hz", nullable=True),
    one_of("measurement.processing.velocity", *VELOCITY_SOURCES),
    # plant=log
    rule("data.path", _one_path, "one log (a path) or null; several logs go in data.paths=[a.csv, b.csv]"),
    rule(
        "data.validation_path",
        _one_path,
        "one log (a path) or null; several logs go in data.validation_paths=[a.csv, b.csv]",
    ),
    fraction("data.validation_fraction"),
    one_of("data.time_unit", "s", "ms", "us", "ns"),
    one_of("data.position_unit", "rad", "deg"),
    positive("data.rate_hz", nullable=True),
    integer_at_least("data.min_samples", 2),
    rule(
        "data.drive_gains",
        lambda v: v is None or (isinstance(v, list | tuple) and all(_number(x) and x != 0 for x in v)),
        "null or a list of non-zero numbers (N·m/A per joint)",
    ),
    one_of("data.velocity", *VELOCITY_SOURCES),
    rule(
        "data.column_map",
        lambda v: v is None or (isinstance(v, dict) and all(_SCHEMA_COLUMN.match(str(k)) for k in v)),
        "null or a mapping whose keys are schema names: t, q1…qN, dq1…dqN, tau1…tauN, current1…currentN, "
        "or a block q, dq, tau, current (an npz array, or the prefix of per-joint columns: {q: pos_})",
    ),
    # statistics
    integer_at_least("statistics.resamples", 0),
    positive("statistics.block_s"),
    fraction("statistics.confidence"),
    integer_at_least("statistics.seed", 0),
    # task settings (each key belongs to one task)
    positive("task.verify_rate_hz"),
    positive_list("task.durations", "s"),
    fraction("task.knee_fraction"),
    rule(
        "task.seeds",
        lambda v: isinstance(v, list) and bool(v) and all(_integer(s) and s >= 0 for s in v),
        "a non-empty list of integers ≥ 0",
    ),
    Rule("task.noise", lambda v, cfg: v in _noise_presets(cfg), lambda cfg: f"one of {_noise_presets(cfg)}"),
    rule(
        "task.noise_presets",
        lambda v: all(_number(x) and x >= 0 for preset in v.values() for x in preset.values()),
        "presets of noise levels ≥ 0",
    ),
    integer_at_least("task.n_seeds", 1),
    integer_at_least("task.tool_motion_candidates", 1),
    *painting_rules("task."),
    *painting_rules("task.painting."),
    # task=monitor
    positive("task.observer_gain"),
    positive("task.velocity_cutoff_hz"),
    positive("task.coulomb_smoothing"),
    positive("task.false_alarm_rate"),
    rule("task.margin", lambda v: _number(v) and v >= 1, "a number ≥ 1"),
    rule("task.residual_margin", lambda v: _number(v) and v >= 1, "a number ≥ 1"),
    non_negative("task.min_duration"),
    rule("task.release", lambda v: _number(v) and 0 < v <= 1, "a number in (0, 1]"),
    non_negative("task.min_force"),
)
"""The settings checked, by key."""

_COPY = re.compile(r"^\$\{([\w.]+)\}$")
"""A value that is another key's value (``${seed}``)."""


def _copied_from(cfg: Any, key: str) -> str | None:
    """The key whose value ``key`` copies (``plant.seed: ${seed}`` → ``seed``), else None."""
    from omegaconf import OmegaConf

    parent_key, _, name = key.rpartition(".")
    parent = OmegaConf.select(cfg, parent_key, default=None) if parent_key else cfg
    node = parent._get_node(name) if OmegaConf.is_dict(parent) and name in parent else None
    match = _COPY.match(str(node._value())) if node is not None else None
    return match.group(1) if match else None


def _unknown_below(node: Any, prefix: str) -> Iterator[str]:
    from omegaconf import DictConfig, OmegaConf

    if not isinstance(node, DictConfig):
        return
    schema = OmegaConf.get_type(node)
    fields = [f.name for f in dataclasses.fields(schema)] if dataclasses.is_dataclass(schema) else None
    for key in map(str, node):
        if fields is not None and key not in fields:
            assert isinstance(schema, type)
            settings = ", ".join(name for name in fields if not name.startswith("_"))
            yield f"{prefix}{key}: no such setting ({schema.__name__}: {settings})"
        else:
            yield from _unknown_below(node._get_node(key), f"{prefix}{key}.")


def _missing_below(node: Any, prefix: str) -> Iterator[str]:
    """Keys under ``node`` whose value is mandatory and unset (``???``); interpolations are left
    unresolved (a copied value may dangle where its source is another plant's)."""
    from omegaconf import DictConfig, OmegaConf

    if not isinstance(node, DictConfig):
        return
    for key in map(str, node):
        if OmegaConf.is_missing(node, key):
            yield f"{prefix}{key}"
        elif not OmegaConf.is_interpolation(node, key):
            yield from _missing_below(node[key], f"{prefix}{key}.")


def unknown_keys(cfg: Any) -> list[str]:
    """Keys of typed nodes that their schema does not have (added with ``+key=value``).

    The root is left out: its schema types ``seed`` and ``experiment_name`` and leaves the rest open.
    """
    return [found for key in cfg for found in _unknown_below(cfg._get_node(key), f"{key}.")]


def violations(cfg: Any, rules: Iterable[Rule] = RULES) -> list[str]:
    """One line per rule that a value of ``cfg`` (a composed Hydra config) breaks, per unknown key and per
    mandatory value left unset."""
    from omegaconf import OmegaConf

    rules = tuple(rules)
    checked = {r.key for r in rules}
    problems = list(unknown_keys(cfg))
    # a mandatory value left out (``???`` in the option's YAML, e.g. robot=urdf's path)
    problems += [f"{key}: must be set ({key}=…)" for key in _missing_below(cfg, "")]
    for each in rules:
        if _copied_from(cfg, each.key) in checked:  # not resolved: the copy may dangle (painting on logs)
            continue
        value = OmegaConf.select(cfg, each.key, default=_MISSING, throw_on_missing=False)
        if value is _MISSING or OmegaConf.is_missing(cfg, each.key):
            continue
        value = plain(value)
        if not each.accepts(value, cfg):
            problems.append(f"{each.key}={value!r}: must be {each.expected(cfg)}")
    return problems


def check_config(cfg: Any, rules: Iterable[Rule] = RULES) -> None:
    """Raise :class:`ConfigError` listing every setting of ``cfg`` that breaks its rule."""
    problems = violations(cfg, rules)
    if problems:
        raise ConfigError("invalid settings:\n  " + "\n  ".join(problems))
