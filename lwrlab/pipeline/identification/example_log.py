"""Task ``write_example_logs``: record the simulated robot's exciting and validation motions as logs.

The logs follow the schema of :mod:`lwrlab.io.logs`, so they stand for what a real robot would
record; ``plant=log`` then identifies from them exactly as from a real robot's logs. With
``task.file_format=bag`` they are ROS 2 bags of ``sensor_msgs/msg/JointState`` on ``/joint_states``
(the robot's joint names, positions, velocities, efforts), as ``ros2 bag record /joint_states``
writes them while a robot plays a motion: the route of a reader with no robot yet, from a designed
motion (``trajectory.from_file=…/exciting_motion.yaml``) to an identified model::

    lwrlab task=write_example_logs                       # → outputs/example_logs/*.csv
    lwrlab plant=log data.path=outputs/example_logs/identification.csv \\
        data.validation_path=outputs/example_logs/validation.csv
    lwrlab task=write_example_logs task.file_format=bag  # → outputs/example_logs/*_bag/
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from lwrlab.errors import ConfigError
from lwrlab.io.logs import write_log
from lwrlab.io.rosbag import write_joint_states
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement

FILE_FORMATS = ("csv", "parquet", "npz", "bag")
"""``task.file_format``: a file suffix, or ``bag`` (a ROS 2 bag folder ``<role>_bag``)."""


def _log_path(folder: Path, role: str, file_format: str) -> Path:
    return folder / (f"{role}_bag" if file_format == "bag" else f"{role}.{file_format}")


def _write(measurement: Measurement, robot: RobotModel, path: Path, file_format: str) -> None:
    if file_format != "bag":
        write_log(measurement, path)
        return
    if (path / "metadata.yaml").is_file():  # a bag of an earlier run: replaced, as a file would be
        shutil.rmtree(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_joint_states(path, measurement.t, measurement.q, measurement.tau, robot.joint_names, measurement.dq)


def write_example_logs(
    cfg: Any, output_dir: Path, directory: str = "outputs/example_logs", file_format: str = "csv"
) -> dict[str, float]:
    """Simulate the configured plant on the configured motions; write ``identification`` and
    ``validation`` logs into ``directory`` (and the run folder). Returns sample counts."""
    from hydra.utils import instantiate

    if file_format not in FILE_FORMATS:
        raise ConfigError(
            f"task.file_format={file_format}: not a log format; use one of {list(FILE_FORMATS)}"
        )
    robot = instantiate(cfg.robot)
    plant = instantiate(cfg.plant)(robot=robot)
    metrics = {}
    for role, source in (("identification", cfg.trajectory), ("validation", cfg.validation)):
        motion = instantiate(source).sample(robot, cfg.measurement.rate_hz)
        measurement = plant.measure(motion)
        for folder in (Path(directory), output_dir):
            _write(measurement, robot, _log_path(folder, role, file_format), file_format)
        metrics[f"{role}_samples"] = float(len(measurement.t))
        written = _log_path(Path(directory), role, file_format)
        print(f"{role} log: {written} ({len(measurement.t)} samples, {robot.n_joints} joints)")
    return metrics
