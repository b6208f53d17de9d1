"""Schemas of the ``plant`` group: the simulated robot and the recorded logs (``plugins/plants/``)."""

from __future__ import annotations

from typing import Any

from lwrlab.config.schema import Instantiable, schema


@schema
class SimulatedPlantSettings(Instantiable):
    """``conf/plant/simulated.yaml``: a simulated robot standing in for the real one."""

    mode: str
    """``playback`` (exact motion) or ``closed_loop`` (PD + gravity compensation, ABA)."""
    parameter_spread: float
    """Relative spread of every segment's inertial parameters."""
    friction_spread: float
    """Relative spread of Coulomb and viscous friction."""
    torque_noise_std: Any
    """N·m, joint-torque sensor noise σ_τ: a number or one per joint (a union: see the rules)."""
    encoder_noise_std: Any
    """rad, encoder noise σ_q: a number or one per joint."""
    encoder_resolution: float
    """rad, quantisation step (0 = none)."""
    seed: int
    """Seed of the truth and the noise."""
    kp: list[float] | None
    """N·m/rad per joint for closed_loop (null = 2000)."""
    kd: list[float] | None
    """N·m·s/rad per joint for closed_loop (null = 60)."""
    substeps: int
    """Integration steps per 1 ms sample in closed_loop."""
    show_progress: bool
    """Progress bar while simulating."""
    tool: Any
    """The tool on the flange (config group ``tool``), null = none."""


@schema
class LogReaderSettings:
    """How recorded logs are found and read (:mod:`lwrlab.io.logs`)."""

    path: Any
    """Identification log (.csv, .parquet, .npz, or a ROS 2 bag folder) … Untyped, so that a list given
    here is refused by the checks with the key for several logs (``data.paths``), not by OmegaConf."""
    paths: list[str] | None
    """… or several, processed one by one and stacked after processing."""
    validation_path: Any
    """Validation log … (untyped, as ``path``)"""
    validation_paths: list[str] | None
    """… or several, each scored on its own."""
    validation_fraction: float
    """Without validation logs: the last fraction of each identification log validates."""
    column_map: Any
    """Schema name → name in the file (``{t: timestamp, q1: pos_0}``; npz: ``{t: times, q: positions}``),
    or null. Untyped: OmegaConf cannot merge a mapping given on the command line into a typed null."""
    time_unit: str
    """``s``, ``ms``, ``us`` or ``ns``."""
    position_unit: str
    """``rad`` or ``deg`` (positions and velocities)."""
    drive_gains: list[float] | None
    """N·m/A per joint: torques from columns current1…N as gain · current."""
    rate_hz: float | None
    """Hz, uniform grid for irregular time stamps (null = the median period)."""
    min_samples: int
    """Fewest samples a log may have."""
    topic: str | None
    """ROS 2 bags: the JointState topic (null = the bag's only one)."""
    fitted_joints: list[Any] | None
    """Joints whose torques are fitted and scored (names or 1-based numbers); null: every joint. A
    joint whose effort signal is no torque (a gripper, a wrist reading zero) is left out."""


@schema
class DataSettings(LogReaderSettings):
    """``data`` of ``conf/plant/log.yaml``: what the user sets to identify from logs."""

    velocity: str
    """``auto``, ``logged`` or ``differentiated`` (becomes ``measurement.processing.velocity``)."""


@schema
class LogPlantSettings(LogReaderSettings, Instantiable):
    """``plant`` of ``conf/plant/log.yaml``: the log reader, its settings copied from ``data``."""
