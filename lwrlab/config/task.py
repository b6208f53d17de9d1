"""Schemas of the ``task`` group (``conf/task/``): each task's keywords besides ``(cfg, output_dir)``.

A task is a function of :mod:`lwrlab.pipeline` built partially from its node (``_partial_: true``);
the fields below are the keywords it receives. Nodes Hydra builds into objects (a criterion, a
classifier, a motion) are typed ``Any``: their own group types them, or their plugin checks them.
"""

from __future__ import annotations

from typing import Any

from lwrlab.config.painting import PaintingTask
from lwrlab.config.schema import Instantiable, schema


@schema
class IdentificationTask(Instantiable):
    """``task=identification``: exciting motion → robot → processing → estimation → cross-validation."""

    motion_format: str
    """The 1 kHz motions played, as ``parquet`` or ``csv``."""


@schema
class ExcitationTask(Instantiable):
    """``task=excitation``: optimise the exciting motion and write it."""

    verify_rate_hz: float
    """Hz, rate at which every constraint is checked against the true limits."""
    known_logs: list[str] | None
    """Logs already recorded on this robot (read by ``plant=log``): the motion is designed for what
    they leave unknown."""
    known_model: str | None
    """An identified model (its ``identified_model.yaml`` or run folder, or an MLflow model URI): its
    base-parameter covariance is known information too."""
    targets: list[Any] | None
    """Where the model will be used (motion files, logs, inline states: lwrlab/io/target_motions.py):
    the report gives the expected torque std along them, and ``criterion=target_variance`` aims at them."""


@schema
class DurationStudyTask(Instantiable):
    """``task=duration_study`` (Fig. 5): optimal cost of each criterion for each duration."""

    criteria: dict[str, Any]
    """Criteria compared, by name (options of the ``criterion`` group)."""
    durations: list[float]
    """s, the durations T_F."""
    knee_fraction: float
    """A step below this share of the criterion's total decrease is not significant."""


@schema
class CriteriaComparisonTask(Instantiable):
    """``task=criteria_comparison`` (Fig. 6): each criterion's optimum identified and cross-validated."""

    criteria: dict[str, Any]
    """Criteria compared, by name (options of the ``criterion`` group)."""
    seeds: list[int]
    """Seeds of the truths and noises the comparison averages over."""


@schema
class NoisePreset:
    """One noise level of the estimator benchmark (BIRDy's presets)."""

    encoder_noise_deg: float
    """°, encoder noise σ_q."""
    torque_noise_std: float
    """N·m, torque noise σ_τ."""


@schema
class EstimatorBenchmarkTask(Instantiable):
    """``task=estimator_benchmark``: one (estimator, noise preset, seed) cell of the benchmark."""

    noise: str
    """The preset of this cell: a key of ``noise_presets``."""
    noise_presets: dict[str, NoisePreset]
    """Noise presets by name."""


@schema
class LoggedPayloadInputs(Instantiable):
    """Logs of the robot without and with a payload (tasks ``payload`` and ``drive_gains``)."""

    unloaded_paths: list[str] | None
    """Logs of the robot without the payload."""
    loaded_paths: list[str] | None
    """Logs of the robot carrying the payload."""
    weighted: bool
    """Gautier's weighting per (log set, joint)."""


@schema
class PayloadTask(LoggedPayloadInputs):
    """``task=payload``: a payload identified from logs and recognised in the tool library."""

    unloaded_model: str | None
    """Or an earlier run's identified model for the unloaded robot: its identified_model.yaml (or
    folder), or an MLflow model (``runs:/<run id>/model``, ``models:/<name>@<alias>``, a run id)."""
    method: str | None
    """``joint``, ``payload_only``, or null (joint with logs, payload_only with a model)."""
    consistent: bool
    """SDP with the payload's pseudo-inertia ⪰ 0."""
    library: list[str] | None
    """Tools of the look-up (null = every tool in conf/tool/)."""
    truth: str | None
    """A library tool known to be the payload (simulated logs): errors in metrics."""


@schema
class KnownPayload:
    """What is known of the payload of a drive-gain identification (flange frame)."""

    mass: float | None
    """kg (required unless ``tool`` is given)."""
    com: list[float] | None
    """m, [x, y, z] if known."""
    tool: str | None
    """Or a library tool (conf/tool/): all 10 parameters known."""


@schema
class DriveGainsTask(LoggedPayloadInputs):
    """``task=drive_gains``: joint drive gains (N·m/A) from current logs, unloaded and with a payload."""

    payload: KnownPayload
    """What is known of the payload."""
    method: str
    """``least_squares`` (Gautier and Briot) or ``total_least_squares``."""
    true_gains: list[float] | None
    """The true gains when known (simulation): errors in metrics."""


@schema
class ToolStudy(Instantiable):
    """Tools identified by eq. (7) on the simulated robot and recognised (tool tasks)."""

    library: list[str] | None
    """Tools of the look-up (null = every tool in conf/tool/)."""
    method: str
    """``joint`` (eq. 7: robot and tool together) or ``payload_only`` (robot first, then tool)."""
    weighted: bool
    """Gautier's weighting per (motion, joint) row group."""
    consistent: bool
    """SDP with the tool's pseudo-inertia ⪰ 0."""
    tool_motion: Any
    """The motion carrying the tool (a ``trajectory`` plugin node, partial: seeds vary)."""
    tool_motion_candidates: int
    """Candidate motions; the one exciting the tool best is kept."""


@schema
class Table3ToolsTask(ToolStudy):
    """``task=table3_tools`` (Table III): each tool's 10 inertial parameters, recognised."""

    tools: list[str]
    """Library names of the tools identified."""


@schema
class ToolRecognitionBenchmarkTask(ToolStudy):
    """``task=tool_recognition_benchmark``: every classifier × library tool × seed."""

    classifiers: dict[str, Any]
    """Classifiers compared, by name (options of the ``classifier`` group)."""
    n_seeds: int
    """Robot truths and noise draws per tool: seeds ``seed`` … ``seed + n_seeds − 1``."""


@schema
class WriteExampleLogsTask(Instantiable):
    """``task=write_example_logs``: the simulated motions written as logs."""

    directory: str
    """Where the logs go (also copied into the run folder)."""
    file_format: str
    """Log format: ``csv``, ``parquet`` or ``npz`` (the file suffix), or ``bag``: a ROS 2 bag of
    ``sensor_msgs/msg/JointState`` on ``/joint_states`` (folder ``<role>_bag``), as a robot records."""


@schema
class MonitorTask(Instantiable):
    """``task=monitor``: external torques, contact forces and detected contacts of logs."""

    model: str | None
    """An identified_model.yaml (or its run folder), or an MLflow model (``runs:/<run id>/model``,
    ``models:/<name>/<version>``, ``models:/<name>@<alias>``, a run id); null: the robot config's model."""
    calibration_paths: list[str] | None
    """Contact-free logs for the thresholds; null: the logs the model's run identified from."""
    observer_gain: float
    """1/s, K of the momentum observer."""
    velocity_cutoff_hz: float
    """Hz, velocity low-pass: causal for the observer (its q and τ through the same filter), zero-phase
    on q and τ for the direct residual."""
    coulomb_smoothing: float
    """rad/s, ε of FC·tanh(q̇/ε)."""
    false_alarm_rate: float
    """Stated false alarms per hour."""
    margin: float
    """Factor ≥ 1 on the calibrated levels."""
    residual_margin: float
    """Factor ≥ 1 on the direct residual's calibrated levels."""
    min_duration: float
    """s above threshold before a contact is raised."""
    release: float
    """Share of the threshold every joint must fall below to end a contact."""
    thresholds: str
    """``state`` (following the friction band, falling to the noise and the friction held at rest) or
    ``constant`` (one per joint)."""
    friction_drift: float
    """``state`` only: share of its friction a run may differ by from the calibration's."""
    rest_thresholds: str
    """``state`` only, where the arm stands still: ``model`` (the model at rest: noise within the
    calibration's rests, friction band, gravity error) or ``moving`` (a moving arm's formula at the
    band at rest)."""
    frame: str | None
    """Frame of the robot where the contact load is mapped; null: the flange, else the last link's."""
    point: list[float] | None
    """m, a point of ``frame`` taking a pure force; null: the frame's wrench."""
    truth_contacts: str | None
    """CSV of known contacts (simulation): detection scores."""
    truth_torque: str | None
    """Parquet of the true external torque: RMS errors."""
    min_force: float
    """N, weaker true contacts count neither as missed nor as false alarms."""


@schema
class LiveMonitorTask(MonitorTask):
    """``task=live_monitor``: the monitor on a robot's ROS 2 joint states, live (every
    ``task=monitor`` setting, the same calibration)."""

    joint_names: list[str] | None
    """The names the joint states use, in the model's joint order; null: the model's joint names."""
    drive_gains: list[float] | None
    """N·m/A per joint: the efforts are motor currents; null: as the model's drive train says."""
    topics: dict[str, str]
    """ROS 2 topic of each stream: ``joint_states`` (in), ``external_torque``, ``contact_wrench``,
    ``collision``, ``diagnostics`` (out)."""
    input_qos: str
    """QoS profile of the joint states: ``default`` (reliable, keep last 10) or ``sensor_data``."""
    output_qos: str
    """QoS profile of what the monitor publishes."""
    domain_id: int | None
    """ROS 2 domain; null: ``ROS_DOMAIN_ID``."""
    localhost_only: bool | None
    """Loopback only; null: as ROS 2's environment says (``ROS_AUTOMATIC_DISCOVERY_RANGE``)."""
    rate_hz: float | None
    """Hz, the joint states' rate the causal filter is designed for; null: measured on the first
    samples (the observer's start-up)."""
    duration_s: float | None
    """s, stop after this long; null: until SIGINT/SIGTERM or idle."""
    idle_stop_s: float | None
    """s without a sample (after the first) that stops the run; null: never."""
    wait_s: float
    """s to wait for the first sample before failing."""
    max_gap_s: float
    """s between two samples' stamps beyond which the observer restarts (samples lost: its filter
    and momentum cannot bridge the gap)."""
    diagnostics_hz: float
    """Hz of ``/diagnostics`` (also on every contact raised or ended)."""
    record: bool
    """Record the inputs and outputs as a rosbag2 (MCAP) in the run folder (``live_bag``)."""


@schema
class SimRobotTask(Instantiable):
    """``task=sim_robot``: a simulated arm that speaks ROS 2 like a ``ros2_control`` robot."""

    motion: str
    """``trajectory``: play the configured ``trajectory`` (held still ``start_delay_s`` before and
    ``hold_after_s`` after it); ``hold``: stand still at ``hold_pose`` for ``duration_s``."""
    hold_pose: list[float] | None
    """rad, the pose held (``motion: hold``); null: the middle of the joint ranges."""
    rate_hz: float
    """Hz, the joint states' rate (the simulation's step)."""
    duration_s: float
    """s, how long ``motion: hold`` stands."""
    hold_after_s: float
    """s the robot stands still after the motion."""
    realtime: bool
    """Publish at the wall clock's pace (a robot); false: as fast as it goes (tests)."""
    stamps: str
    """``wall`` (the header stamp is the wall clock, as a robot's driver stamps) or ``sim`` (the
    simulation's time from 0)."""
    pushes: list[dict[str, Any]] | None
    """Scripted pushes: ``{start, duration, link, force: [x, y, z], point: [x, y, z]}`` (s, N, m)."""
    random_pushes: int
    """Pushes drawn at random (links, directions, 20–60 N) beside the scripted ones."""
    seed: int
    """Seed of the sensors' noise and the random pushes (the true robot is ``plant``'s, from its seed)."""
    start_delay_s: float
    """s the robot stands still before the motion starts."""
    push_force: list[float]
    """N, the range of the random pushes' peak forces."""
    topics: dict[str, str]
    """ROS 2 topic of each stream: ``joint_states``, ``truth_torque`` (the true external torque, a
    JointState's effort), ``truth_contact`` (std_msgs/Bool: a force acts)."""
    qos: str
    """QoS profile of the joint states."""
    domain_id: int | None
    """ROS 2 domain; null: ``ROS_DOMAIN_ID``."""
    localhost_only: bool | None
    """Loopback only; null: as ROS 2's environment says."""
    wait_for_subscriber_s: float
    """s to wait for a subscriber of the joint states before publishing (0: do not wait)."""


@schema
class LivePaintingSafety:
    """The live painting's guards (:class:`lwrlab.live.painting_loop.SafetySettings`)."""

    max_state_age_s: float
    """s, the oldest the last joint state may be before commanding stops."""
    force_limit_n: float
    """N, pressing-force estimate beyond which the roller retracts."""
    contact_n: float
    """N, pressing force from which the roller counts as touching."""
    contact_lost_s: float
    """s below ``contact_n`` while painting (once touched) that count as a lost contact."""
    speed_fraction: float
    """Share of the description's joint speed limits a command may use."""
    acceleration_fraction: float
    """Share of the description's joint acceleration limits a command may use."""
    retract_distance: float
    """m along the wall normal a retraction moves."""
    retract_speed: float
    """m/s of the retraction and of the straight approach."""
    clearance: float
    """m off the wall where the move to the start ends."""
    move_speed_fraction: float
    """Share of the joint speed and acceleration limits of the move to the start."""


@schema
class LivePaintingTask(PaintingTask):
    """``task=live_painting``: the painting controller as its own process, over ROS 2 (every
    ``task=painting`` setting, the same plan)."""

    rate_hz: float
    """Hz of the joint states, one control period each."""
    topics: dict[str, str | None]
    """ROS 2 topic of each stream: ``joint_states`` (in), ``commands``, ``force_estimate``,
    ``progress``, ``diagnostics`` (out), ``truth_force`` (in, the robot's force sensor; null: none)."""
    qos: str
    """QoS profile of every stream."""
    domain_id: int | None
    """ROS 2 domain; null: ``ROS_DOMAIN_ID``."""
    localhost_only: bool | None
    """Loopback only; null: as ROS 2's environment says."""
    wait_s: float
    """s to wait for the first joint state before failing."""
    diagnostics_hz: float
    """Hz of ``/diagnostics`` and of the progress."""
    safety: LivePaintingSafety
    """The guards."""
    record: bool
    """Record the inputs and outputs as a rosbag2 (MCAP) in the run folder (``live_bag``)."""
    robot: dict[str, Any]
    """The simulated robot's own settings (``task=sim_painting_robot``): ``start_pose``,
    ``joint_gains``, ``stalls``, ``wall_moves``, ``torque_jumps``, ``lockstep_s``, ``duration_s``,
    ``idle_stop_s``."""


@schema
class PaperChainTask(Instantiable):
    """``task=paper_chain``: the whole chain of the paper's Fig. 1."""

    painting: PaintingTask
    """The painting stage's settings (``conf/task/painting.yaml``, narrowed)."""


TASK_SCHEMAS: dict[str, type] = {
    "identification": IdentificationTask,
    "excitation": ExcitationTask,
    "duration_study": DurationStudyTask,
    "criteria_comparison": CriteriaComparisonTask,
    "estimator_benchmark": EstimatorBenchmarkTask,
    "payload": PayloadTask,
    "drive_gains": DriveGainsTask,
    "table3_tools": Table3ToolsTask,
    "tool_recognition_benchmark": ToolRecognitionBenchmarkTask,
    "write_example_logs": WriteExampleLogsTask,
    "monitor": MonitorTask,
    "live_monitor": LiveMonitorTask,
    "sim_robot": SimRobotTask,
    "live_painting": LivePaintingTask,
    "sim_painting_robot": LivePaintingTask,
    "paper_chain": PaperChainTask,
    "painting": PaintingTask,
}
"""Schema of each task option, by option name."""
