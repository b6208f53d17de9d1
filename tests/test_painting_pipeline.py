"""The painting stage through Hydra (experiment=paper_table4_force) on a shrunken config."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate

CONF = Path(__file__).resolve().parents[1] / "conf"
# one roller, 4 s identification motions, one SLSQP start, 2 s approach + 1.5 s of painting, two cases
SHORT = [
    "experiment=paper_table4_force",
    "trajectory=multisine",
    "trajectory.duration=4",
    "task.tool_motion.duration=4",
    "measurement.processing.rate_hz=1000",
    "task.tools=[large_roller]",
    "task.path.starting_swivels=[-1.6]",
    "task.models=[identified]",
    "task.feedbacks=[estimate]",
    "task.contact.max_duration=3.5",
]


@pytest.mark.slow
def test_painting_preset_writes_table4_and_presses_with_30_newtons(tmp_path: Path) -> None:
    with initialize_config_dir(str(CONF), version_base="1.3"):
        cfg = compose("config", overrides=SHORT)
    metrics = instantiate(cfg.task)(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "table4_force.csv")
    assert list(table.columns) == ["roller", "model", "feedback", "comparison", "rms", "nrms"]
    assert set(table.model) == {"identified", "position"}
    row = table[(table.model == "identified") & (table.comparison == "estimated/measured")].iloc[0]
    assert row.rms < 1.0  # the estimate follows the wall sensor
    runs = pd.read_csv(tmp_path / "painting_runs.csv").set_index("model")
    assert runs.loc["identified", "mean_measured_N"] == pytest.approx(-30.0, abs=2.0)
    paths = pd.read_csv(tmp_path / "painting_paths.csv")
    assert paths.recognised[0] == "large_roller" and paths.dY[0] <= paths.roller_width_m[0] + 1e-9
    assert np.isfinite(metrics["duration_s_large_roller"])
    for name in ("fig12_large_roller.png", "fig13_large_roller.png", "summary.md"):
        assert (tmp_path / name).is_file(), name
