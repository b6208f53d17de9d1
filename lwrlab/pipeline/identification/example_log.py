"""Task ``write_example_logs``: record the simulated robot's exciting and validation motions as logs.

The logs follow the schema of :mod:`lwrlab.io.logs`, so they stand for what a real robot would
record; ``plant=log`` then identifies from them exactly as from a real robot's logs::

    lwrlab task=write_example_logs                       # → outputs/example_logs/*.csv
    lwrlab plant=log data.path=outputs/example_logs/identification.csv \\
        data.validation_path=outputs/example_logs/validation.csv
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from lwrlab.io.logs import write_log


def write_example_logs(
    cfg: Any, output_dir: Path, directory: str = "outputs/example_logs", file_format: str = "csv"
) -> dict[str, float]:
    """Simulate the configured plant on the configured motions; write ``identification`` and
    ``validation`` logs into ``directory`` (and the run folder). Returns sample counts."""
    from hydra.utils import instantiate

    robot = instantiate(cfg.robot)
    plant = instantiate(cfg.plant)(robot=robot)
    metrics = {}
    for role, source in (("identification", cfg.trajectory), ("validation", cfg.validation)):
        motion = instantiate(source).sample(robot, cfg.measurement.rate_hz)
        measurement = plant.measure(motion)
        for folder in (Path(directory), output_dir):
            write_log(measurement, folder / f"{role}.{file_format}")
        metrics[f"{role}_samples"] = float(len(measurement.t))
        written = Path(directory) / f"{role}.{file_format}"
        print(f"{role} log: {written} ({len(measurement.t)} samples, {robot.n_joints} joints)")
    return metrics
