"""Settings checked in two steps: types and keys when Hydra composes (the schemas of lwrlab/config/),
ranges when the job starts (the rules of lwrlab/pipeline/config_checks.py); both name the key.

That every option and preset composes and passes is tests/test_config_tree.py's.
"""

from __future__ import annotations

import dataclasses
import textwrap
import typing
from pathlib import Path

import pytest
from composing import compose_config
from hydra.errors import ConfigCompositionException
from omegaconf import OmegaConf

from lwrlab.config import SCHEMAS
from lwrlab.errors import ConfigError
from lwrlab.pipeline.config_checks import RULES, check_config, violations


@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (("seed=-2",), "seed=-2: must be an integer ≥ 0"),
        (("plant.torque_noise_std=abc",), "plant.torque_noise_std='abc': must be a number ≥ 0"),
        (("plant.torque_noise_std=-1",), "plant.torque_noise_std=-1: must be a number ≥ 0"),
        (("plant.encoder_noise_std=[0.1,-0.1]",), "plant.encoder_noise_std=[0.1, -0.1]"),
        (("plant.mode=open_loop",), "plant.mode='open_loop': must be one of ['playback', 'closed_loop']"),
        (("plant.seed=-1",), "plant.seed=-1: must be an integer ≥ 0"),
        (("plant.kp=[2000,0]",), "plant.kp=[2000.0, 0.0]: must be null or a non-empty list of numbers > 0"),
        (("trajectory.duration=0",), "trajectory.duration=0: must be a number > 0"),
        (("measurement.rate_hz=-5",), "measurement.rate_hz=-5.0"),
        (
            ("measurement.processing.cutoff_hz=fast",),
            "measurement.processing.cutoff_hz='fast': must be a number > 0 (Hz), auto or null",
        ),
        (
            ("measurement.processing.cutoff_hz=600",),
            "measurement.processing.cutoff_hz=600: must be below the Nyquist frequency",
        ),
        (
            ("measurement.processing.rate_hz=0",),
            "measurement.processing.rate_hz=0.0: must be a number > 0 or null",
        ),
        (("measurement.processing.difference_accuracy=3",), "must be one of [2, 4]"),
        (("measurement.processing.velocity=measured",), "measurement.processing.velocity='measured'"),
        (("statistics.resamples=-1",), "statistics.resamples=-1: must be an integer ≥ 0"),
        (("statistics=block_bootstrap", "statistics.confidence=1"), "statistics.confidence=1.0"),
        (("statistics=block_bootstrap", "statistics.seed=-3"), "statistics.seed=-3"),
        (("task=excitation", "task.verify_rate_hz=0"), "task.verify_rate_hz=0.0: must be a number > 0"),
        (("task=duration_study", "task.durations=[2,0]"), "task.durations=[2.0, 0.0]"),
        (
            ("task=duration_study", "task.knee_fraction=2"),
            "task.knee_fraction=2.0: must be a number in (0, 1)",
        ),
        (("task=criteria_comparison", "task.seeds=[]"), "task.seeds=[]: must be a non-empty list"),
        (
            ("task=estimator_benchmark", "task.noise=loud"),
            "task.noise='loud': must be one of ['high_position', 'high_torque', 'standard']",
        ),
        (
            ("task=estimator_benchmark", "task.noise_presets.standard.torque_noise_std=-1"),
            "task.noise_presets=",
        ),
        (("task=tool_recognition_benchmark", "task.n_seeds=0"), "task.n_seeds=0: must be an integer ≥ 1"),
        (("task=table3_tools", "task.tool_motion_candidates=0"), "task.tool_motion_candidates=0"),
        (("task=painting", "task.contact.substeps=0"), "task.contact.substeps=0: must be an integer ≥ 1"),
        (
            ("task.painting.contact.duration_scale=0",),
            "task.painting.contact.duration_scale=0.0: must be a number > 0",
        ),
        (("task=painting", "plant.torque_noise_std=-1"), "plant.torque_noise_std=-1"),
        (("plant=log", "data.path=[a.csv]"), "several logs go in data.paths=[a.csv, b.csv]"),
        (
            ("task=identification", "+plant.torque_noise_stdd=0.1"),
            "plant.torque_noise_stdd: no such setting (SimulatedPlantSettings: mode, parameter_spread",
        ),
    ],
)
def test_a_value_out_of_range_fails_at_the_start_naming_its_key(
    overrides: tuple[str, ...], fragment: str
) -> None:
    cfg = compose_config(*overrides)
    with pytest.raises(ConfigError, match="invalid settings") as error:
        check_config(cfg)
    assert fragment in str(error.value)


@pytest.mark.parametrize(
    "overrides, key",
    [
        (("seed=abc",), "seed"),
        (("seed=1.5",), "seed"),
        (("experiment_name=[a,b]",), "experiment_name"),
        (("measurement.processing.order=2.5",), "measurement.processing.order"),
        (("measurement.processing.trim_s=short",), "measurement.processing.trim_s"),
        (("plant.parameter_spread=abc",), "plant.parameter_spread"),
        (("plant.show_progress=maybe",), "plant.show_progress"),
        (("plant.torque_noise_stdd=0.1",), "plant.torque_noise_stdd"),
        (("plant=log", "data.min_samples=many"), "data.min_samples"),
        (("plant=log", "data.paths=a.csv"), "data.paths"),
        (("statistics.block_s=long",), "statistics.block_s"),
        (("tracking.uri=[a]",), "tracking.uri"),
        (("task=drive_gains", "task.payload.mass=heavy"), "task.payload.mass"),
        (("task=duration_study", "task.durations=[a]"), "task.durations"),
        (("task=payload", "task.weighted=perhaps"), "task.weighted"),
        (("task=painting", "task.wall.width=wide"), "task.wall.width"),
        (("task.painting.contact.substeps=2.5",), "task.painting.contact.substeps"),
    ],
)
def test_a_wrong_type_or_unknown_key_fails_when_composed_naming_it(
    overrides: tuple[str, ...], key: str
) -> None:
    with pytest.raises(ConfigCompositionException) as error:
        compose_config(*overrides)
    message = f"{error.value}\n{error.value.__cause__}"
    assert f"full_key: {key}" in message or f"'{key}'" in message, message


@pytest.mark.parametrize(
    "overrides, key, value",
    [
        (
            ("plant=log", "data.column_map={t: times, q: positions}"),
            "data.column_map",
            {"t": "times", "q": "positions"},
        ),
        (("plant=log", "data.drive_gains=[1,2]"), "data.drive_gains", [1.0, 2.0]),
        (("plant.kp=[1,2,3,4,5,6,7]",), "plant.kp", [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]),
        (
            ("task=payload", "task.library=[large_roller,small_roller]"),
            "task.library",
            ["large_roller", "small_roller"],
        ),
        (("task=drive_gains", "task.payload.com=[0,0,0.1]"), "task.payload.com", [0.0, 0.0, 0.1]),
        (("task=drive_gains", "task.payload.tool=large_roller"), "task.payload.tool", "large_roller"),
    ],
)
def test_a_null_setting_takes_a_list_or_mapping_from_the_command_line(
    overrides: tuple[str, ...], key: str, value: object
) -> None:
    """The README's commands give logs, maps and gains this way: typed nulls must still take them."""
    found = OmegaConf.select(compose_config(*overrides), key)
    assert (OmegaConf.to_container(found) if OmegaConf.is_config(found) else found) == value


def test_a_misspelt_key_in_a_preset_fails_when_composed(tmp_path: Path) -> None:
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "mine.yaml").write_text(
        textwrap.dedent(
            """\
            # @package _global_
            measurement:
              processing:
                cut_off_hz: 5
            """
        )
    )
    with pytest.raises(ConfigCompositionException) as error:
        compose_config(f"hydra.searchpath=[file://{tmp_path}]", "experiment=mine")
    assert "measurement.processing.cut_off_hz" in str(error.value)
    assert "ProcessingSettings" in str(error.value)


def test_a_value_copied_from_a_checked_key_is_reported_once_where_it_is_written() -> None:
    assert violations(compose_config("task=identification", "statistics=block_bootstrap", "seed=-1")) == [
        "seed=-1: must be an integer ≥ 0"
    ]
    found = violations(compose_config("plant=log", "data.paths=[a.csv]", "data.velocity=encoder"))
    assert found == ["data.velocity='encoder': must be one of ['auto', 'logged', 'differentiated']"]


def test_log_settings_are_checked_only_with_the_log_plant() -> None:
    found = violations(
        compose_config(
            "plant=log", "data.paths=[a.csv]", "data.time_unit=minutes", "data.validation_fraction=1.5"
        )
    )
    assert sorted(found) == sorted(
        [
            "data.validation_fraction=1.5: must be a number in (0, 1)",
            "data.time_unit='minutes': must be one of ['s', 'ms', 'us', 'ns']",
        ]
    )
    # a simulated job has no data.* keys: nothing to check there, nothing reported
    assert violations(compose_config("task=identification")) == []


def test_the_nyquist_rule_leaves_logs_to_the_processing() -> None:
    """A log's rate is the file's: a cut-off above the simulated sensors' Nyquist may suit it."""
    assert (
        violations(compose_config("plant=log", "data.paths=[a.csv]", "measurement.processing.cutoff_hz=600"))
        == []
    )


def _schema_keys() -> set[str]:
    """Every dotted key the schemas type (``plant.mode``, ``task.payload.mass``, …)."""

    def walk(schema: type, prefix: str) -> set[str]:
        keys = set()
        for field, kind in typing.get_type_hints(schema).items():
            keys.add(prefix + field)
            if dataclasses.is_dataclass(kind):
                assert isinstance(kind, type)
                keys |= walk(kind, f"{prefix}{field}.")
        return keys

    return {
        key for group, _, schema in SCHEMAS for key in walk(schema, "" if group == "root" else f"{group}.")
    }


def test_every_rule_names_a_typed_key() -> None:
    """A rule on a misspelt key would never fire: each names a key of a schema (or of a motion)."""
    keys = _schema_keys()
    untyped = {rule.key for rule in RULES if rule.key not in keys}
    assert untyped == {"trajectory.duration", "validation.duration"}  # the trajectory group: not typed here
