"""Settings checked at the start of a job: every option and preset passes, every bad value names its key."""

from __future__ import annotations

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from lwrlab.errors import ConfigError
from lwrlab.pipeline.config_checks import RULES, check_config, violations

CONF = Path(__file__).resolve().parents[1] / "conf"


def _compose(*overrides: str):
    with initialize_config_dir(config_dir=str(CONF), version_base=None):
        return compose("config", overrides=list(overrides))


@pytest.mark.parametrize("experiment", sorted(p.stem for p in (CONF / "experiment").glob("*.yaml")))
def test_every_preset_passes(experiment: str) -> None:
    assert violations(_compose(f"experiment={experiment}")) == []


def test_the_log_plant_passes_with_its_defaults() -> None:
    assert violations(_compose("plant=log", "data.paths=[a.csv]", "statistics=block_bootstrap")) == []


@pytest.mark.parametrize(
    "override, fragment",
    [
        ("seed=1.5", "seed=1.5: must be an integer ≥ 0"),
        ("seed=-2", "seed=-2: must be an integer ≥ 0"),
        ("plant.torque_noise_std=abc", "plant.torque_noise_std='abc': must be a number ≥ 0"),
        ("plant.torque_noise_std=-1", "plant.torque_noise_std=-1: must be a number ≥ 0"),
        ("plant.encoder_noise_std=[0.1,-0.1]", "plant.encoder_noise_std=[0.1, -0.1]"),
        ("trajectory.duration=0", "trajectory.duration=0: must be a number > 0"),
        ("measurement.rate_hz=-5", "measurement.rate_hz=-5"),
        (
            "measurement.processing.cutoff_hz=fast",
            "measurement.processing.cutoff_hz='fast': must be a number > 0 (Hz), auto or null",
        ),
        (
            "measurement.processing.rate_hz=0",
            "measurement.processing.rate_hz=0: must be a number > 0 or null",
        ),
        ("measurement.processing.difference_accuracy=3", "must be one of [2, 4]"),
        ("measurement.processing.velocity=measured", "measurement.processing.velocity='measured'"),
        ("statistics.resamples=-1", "statistics.resamples=-1: must be an integer ≥ 0"),
    ],
)
def test_a_bad_value_fails_naming_its_key(override: str, fragment: str) -> None:
    cfg = _compose("task=identification", override)
    with pytest.raises(ConfigError, match="invalid settings") as error:
        check_config(cfg)
    assert fragment in str(error.value)


def test_log_settings_are_checked_only_with_the_log_plant() -> None:
    found = violations(
        _compose("plant=log", "data.paths=[a.csv]", "data.time_unit=minutes", "data.validation_fraction=1.5")
    )
    assert sorted(found) == sorted(
        [
            "data.validation_fraction=1.5: must be a number in (0, 1)",
            "data.time_unit='minutes': must be one of ['s', 'ms', 'us', 'ns']",
        ]
    )
    assert not any(rule.key.startswith("plant.torque") for rule in RULES if rule.key in " ".join(found))
    # a simulated job has no data.* keys: nothing to check there, nothing reported
    assert violations(_compose("task=identification")) == []
