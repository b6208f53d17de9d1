"""Schema of ``task=painting`` (``conf/task/painting.yaml``; also ``task.painting`` of ``paper_chain``)."""

from __future__ import annotations

from typing import Any

from lwrlab.config.schema import Instantiable, schema


@schema
class WallSettings:
    """The painted face (§VI.B), base frame."""

    x: float
    """m, the face's plane x = const."""
    center_y: float
    """m, centre of the painted area."""
    center_z: float
    """m, centre of the painted area."""
    width: float
    """m, along y."""
    height: float
    """m, along z."""


@schema
class PaintingPathSettings:
    """The painting-path optimisation of eq. (12)."""

    rate_hz: float
    """Hz, N_S/T_C of the Σ q̈² term."""
    search_rate_hz: float
    """Hz, joint-trajectory grid during the search."""
    torque_stride: int
    """Search-grid samples between two torque-limit checks."""
    duration_bounds: list[float]
    """s, [low, high] bounds on T_C."""
    min_stroke: float
    """m, smallest Z_u − Z_l."""
    singularity_margin: float
    """Smallest |sin q2|, |sin q4|, |sin q6|."""
    stripe_overlap: float
    """m, neighbouring stripes overlap by at least this."""
    branch: list[int]
    """IK branch: signs of sin q2, sin q4, sin q6."""
    starting_swivels: list[float]
    """rad, SLSQP starts."""


@schema
class ContactSettings:
    """The MuJoCo plant painting in contact (:mod:`lwrlab.plants.mujoco_contact`)."""

    approach_s: float
    """s at the start point while the force builds up (not scored)."""
    standoff: float
    """m off the wall at the start."""
    duration_scale: float
    """< 1 plays the path faster (quick checks only)."""
    max_duration: float | None
    """s, cut every run (quick checks only); null = none."""
    substeps: int
    """MuJoCo steps per 1 ms control period."""
    friction: float
    """Roller–wall sliding friction."""
    contact_time_constant: float
    """s, MuJoCo solref: the cover's compliance."""
    contact_radius: float
    """m, capsule modelling the roller cover."""
    torque_noise_std: Any
    """N·m, joint-torque noise (a number or one per joint; the identification plant's)."""
    encoder_noise_std: Any
    """rad, encoder noise (the identification plant's)."""
    force_noise_std: float
    """N, wall sensor noise."""


@schema
class ForceEstimatorSettings:
    """The external-force estimate of eq. (14) (:mod:`lwrlab.control.force_estimation`)."""

    velocity_cutoff_hz: float
    """Hz, low-pass of the backward-difference velocity."""
    acceleration_cutoff_hz: float
    """Hz, low-pass of the acceleration."""
    wrench_cutoff_hz: float
    """Hz, low-pass of the estimate (and of the sensor, for comparison)."""
    coulomb_smoothing: float
    """rad/s, ε of FC·tanh(q̇/ε)."""


@schema
class PaintingTask(Instantiable):
    """``task=painting`` (Table IV, Figs. 12 and 13): rollers identified, recognised and painted with."""

    tools: list[str]
    """Rollers from the tool library."""
    n_steps: dict[str, int]
    """Horizontal steps of the zig-zag (N_r), per roller."""
    models: list[str]
    """The controller's model: ``identified`` and/or ``cad``."""
    feedbacks: list[str]
    """Force fed back: ``estimate`` (eq. 14) and/or ``sensor``."""
    wall: WallSettings
    """The painted face."""
    path: PaintingPathSettings
    """The path optimisation."""
    contact: ContactSettings
    """The contact simulation."""
    estimator: ForceEstimatorSettings
    """The force estimate."""
    tool_motion: Any
    """The motion carrying the roller for its identification (a ``trajectory`` plugin node)."""
    comparison_controller: Any
    """The comparison position controller (a ``controller`` plugin node), or null."""
