"""The tool stages through Hydra: Table III and the recognition benchmark on shrunken configs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config
from hydra.utils import instantiate

SHORT = [
    "trajectory.duration=4",
    "task.tool_motion.duration=4",
    "task.tool_motion_candidates=2",
    "measurement.processing.rate_hz=1000",
]


def _run(overrides: list[str], output_dir: Path) -> dict[str, float]:
    cfg = compose_config(*overrides)
    return instantiate(cfg.task)(cfg, output_dir)


def test_table3_preset_writes_table3_and_recognises_both_rollers(tmp_path: Path) -> None:
    metrics = _run(["experiment=paper_table3_tools", *SHORT[:3]], tmp_path)  # σ calibrated: decimated
    table = pd.read_csv(tmp_path / "table3_tools.csv")
    assert {"tool", "parameter", "phi", "relative_std", "truth"} <= set(table.columns)
    assert list(table.tool.unique()) == ["large_roller", "small_roller"] and len(table) == 20
    masses = table[table.parameter == "M"].set_index("tool")
    np.testing.assert_allclose(masses.phi, masses.truth, rtol=0.02)  # default noise, 4 s motions
    np.testing.assert_allclose(masses.paper_phi, [0.237, 0.0973])
    assert metrics["recognition_accuracy"] == 1.0
    assert metrics["max_abs_mass_error_pct"] < 2.0
    for name in ("tool_recognition.csv", "tool_motion.csv", "table3_relative_std.png", "summary.md"):
        assert (tmp_path / name).is_file(), name


def test_noiseless_table3_recovers_the_tools_exactly(tmp_path: Path) -> None:
    overrides = [
        "experiment=paper_table3_tools",
        "plant.torque_noise_std=0",
        "plant.encoder_noise_std=0",
        "measurement.processing.cutoff_hz=null",
        "measurement.processing.difference_accuracy=4",
        *SHORT[:3],
    ]
    _run(overrides, tmp_path)
    table = pd.read_csv(tmp_path / "table3_tools.csv")
    for _, rows in table.groupby("tool"):
        scale = np.where(rows.truth != 0, rows.truth.abs(), rows.truth.abs().iloc[4:7].max())
        assert np.max(np.abs(rows.phi - rows.truth) / scale) < 1e-6


@pytest.mark.parametrize("method", ["joint"])  # payload_only: σ without the robot's, too small
def test_recognition_benchmark_reports_every_classifier(tmp_path: Path, method: str) -> None:
    library = "[large_roller,small_roller,cage_roller,brush_50,wall_brush,mini_roller]"
    metrics = _run(
        [
            "experiment=tool_recognition_benchmark",
            "task.n_seeds=1",
            f"task.library={library}",
            f"task.method={method}",
            *SHORT[:3],  # decimated: the covariance the open-set test reads is calibrated
        ],
        tmp_path,
    )
    accuracy = pd.read_csv(tmp_path / "tool_recognition_accuracy.csv").set_index("classifier")
    assert set(accuracy.index) == {"pca_lookup", "nearest", "mahalanobis"}
    assert all(f"accuracy_{name}" in metrics for name in accuracy.index)
    assert accuracy.loc["mahalanobis", "accuracy"] == 1.0
    # open set: each tool held out of the library is called unknown, the library's are not
    held_out = pd.read_csv(tmp_path / "tool_recognition_heldout.csv")
    assert len(held_out) == 3 * 6 and held_out.rejected.all()
    assert (held_out.nearest != held_out.tool).all()
    assert all(metrics[f"heldout_rejected_{name}"] == 1.0 for name in accuracy.index)
    assert (accuracy.called_unknown + accuracy.accuracy <= 1.0).all()
    geometry = pd.read_csv(tmp_path / "geometry_interpolation.csv")
    assert len(set(geometry.tool)) == 6
    assert (tmp_path / "confusion_matrix.png").stat().st_size > 10_000
