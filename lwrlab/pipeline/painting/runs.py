"""The painting runs of the painting stage: their plan, their simulation in MuJoCo, their score (Table IV).

Pure computation: :func:`simulate_painting` plays a roller's optimised path on the contact plant with
each controller (the runs stepped together), :func:`score_run` compares the normal forces (Table IV)
and measures the painted coverage from the contact trace.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from lwrlab.control.contact_loop import ContactCase, ContactRun, PaintingController, simulate_contacts
from lwrlab.control.filters import FirstOrderLowPass
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import SwivelIK
from lwrlab.model.robot import RobotModel
from lwrlab.planning.coverage import GRID_CELL, painted_fraction
from lwrlab.planning.painting_path import sample_path
from lwrlab.planning.path_optimisation import PathSolution
from lwrlab.plants.mujoco_contact import ContactTool, MujocoContactPlant, Wall
from lwrlab.tools.model import Tool

COMPARISONS = (("estimated", "measured"), ("estimated", "desired"), ("measured", "desired"))
"""Table IV's rows: the first signal against the second."""

CONTROL_RATE_HZ = 1000.0
"""The controller's rate (Hz): the paper's 1 kHz loop."""

EDGE = round(0.01 / GRID_CELL)
"""Coverage-grid columns (1 cm) on each side of the painted area left out of its worst interior column."""
IN_CONTACT_N = -1.0
"""Wall-sensor normal force (N) below which the roller counts as pressing (paints)."""


def tcp_transform(tool: Tool) -> np.ndarray:
    """(4, 4) the tool centre point (middle of the contact line) in the flange frame, flange axes."""
    pose = np.eye(4)
    pose[:3, 3] = tool.contact_point
    return pose


def force_errors(first: np.ndarray, second: np.ndarray) -> tuple[float, float]:
    """RMS (N) of ``first − second`` and that RMS over the mean magnitude of ``second`` (%).

    The paper's Table IV calls the ratio NRMS (2.9 N ↔ 9.8 %, 0.2 N ↔ 0.7 %, ``second`` ≈ 30 N); it
    is not the identification's NRMS (RMS over the range of the measured torque), hence its own name
    here, ``rms_over_mean_pct``.
    """
    rms = float(np.sqrt(np.mean((first - second) ** 2)))
    return rms, float(100.0 * rms / np.abs(np.mean(second)))


@dataclass
class RollerPlan:
    """What the painting of one roller starts from."""

    tool: Tool
    """The true roller (the plant carries it)."""
    recognised: Tool
    """The library tool recognition returned (its width and contact point plan the path)."""
    identified_parameters: np.ndarray
    """(10,) identified flange-frame parameters of the roller (eq. 7)."""
    path: PathSolution
    optimisation_s: float

    def summary(self, roller: str) -> dict[str, Any]:
        """A ``painting_paths.csv`` row: recognition, x = [T_C, φ, Z_u, Z_l, Y_0, ΔY], N_r, costs, area."""
        names = ("T_C", "phi", "Z_u", "Z_l", "Y_0", "dY")
        return {
            "roller": roller,
            "recognised": self.recognised.name,
            "roller_width_m": self.recognised.width,
            **dict(zip(names, self.path.parameters.vector().tolist(), strict=True)),
            "N_r": self.path.parameters.n_steps,
            "branch": tuple(self.path.branch),
            **{f"cost_{k}": v for k, v in self.path.cost_terms.items()},
            "painted_area_m2": self.path.painted_area,
            "active_constraints": "; ".join(self.path.active),
            "optimisation_s": self.optimisation_s,
        }


def normal_force_table(
    run: ContactRun, desired_force: float | None, cutoff_hz: float
) -> dict[str, np.ndarray]:
    """Estimated, measured and (when the controller has one) desired normal force (N) while painting.

    The wall sensor's reading passes through the same causal low-pass as the estimate (``cutoff_hz``),
    so both are compared at the bandwidth the controller uses; the stiff contact's kHz ringing,
    which neither the estimate nor a force loop can follow, is left out of both.
    """
    measured = FirstOrderLowPass(cutoff_hz, float(run.t[1] - run.t[0])).apply(
        run.measured_force[:, 0], initial=0.0
    )
    mask = run.painting
    table = {"t": run.t[mask], "estimated": run.estimated_wrench[mask, 0], "measured": measured[mask]}
    if desired_force is not None:
        table["desired"] = np.full(int(mask.sum()), desired_force)
    return table


def reference_poses(
    plan: RollerPlan,
    wall: Wall,
    rate_hz: float,
    approach_s: float,
    duration_scale: float,
    max_duration: float | None,
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4, 4) tool poses at the control rate: ``approach_s`` at the start point, then the path.

    ``duration_scale`` shortens the path in time (same geometry), ``max_duration`` cuts the run
    (s); both are for quick checks only. Returns the poses and the painting mask.
    """
    parameters = plan.path.parameters
    if duration_scale != 1.0:
        parameters = replace(parameters, duration=parameters.duration * duration_scale)
    poses = sample_path(parameters, wall.x, rate_hz).poses()
    approach = np.repeat(poses[:1], round(approach_s * rate_hz), axis=0)
    reference = np.concatenate([approach, poses])
    painting = np.concatenate([np.zeros(approach.shape[0], bool), np.ones(poses.shape[0], bool)])
    if max_duration is not None:
        n = round(max_duration * rate_hz)
        reference, painting = reference[:n], painting[:n]
    return reference, painting


def contact_plant(
    truth: RobotModel, tool: Tool, wall: Wall, contact: Mapping[str, Any], seed: int
) -> MujocoContactPlant:
    """The MuJoCo plant of the true robot carrying ``tool`` against ``wall``, at the control rate.

    ``contact``: the painting task's ``contact`` settings (conf/task/painting.yaml): the plant's
    ``substeps``, ``friction``, ``contact_time_constant``, ``contact_radius`` and noise levels.
    ``seed``: the seed of the sensor noise.
    """
    return MujocoContactPlant(
        truth,
        ContactTool(
            tool.parameters,
            tool.contact_point,
            tool.contact_axis,
            tool.width,
            float(contact["contact_radius"]),
        ),
        wall,
        control_period=1.0 / CONTROL_RATE_HZ,
        substeps=int(contact["substeps"]),
        torque_noise_std=contact["torque_noise_std"],
        encoder_noise_std=float(contact["encoder_noise_std"]),
        force_noise_std=float(contact["force_noise_std"]),
        friction=float(contact["friction"]),
        contact_time_constant=float(contact["contact_time_constant"]),
        seed=seed,
    )


def simulate_painting(
    plan: RollerPlan,
    truth: RobotModel,
    controllers: Sequence[tuple[RobotModel, PaintingController]],
    wall: Wall,
    contact: Mapping[str, Any],
    estimator_settings: Mapping[str, Any],
    seed: int,
) -> list[ContactRun]:
    """The painting runs of one roller in MuJoCo, one per (controller model, controller), stepped together.

    Each run has its own plant (the true robot + roller, the same noise seed) and its controller and
    force estimate (eq. 14) on its controller model; the runs share the path, so the contact loop
    advances them all each period (:func:`~lwrlab.control.contact_loop.simulate_contacts`), each
    equal to that run simulated alone. ``contact`` (conf/task/painting.yaml ``contact``):
    ``approach_s``, ``standoff``, ``duration_scale``, ``max_duration`` (the runs' timing) and the
    plant's settings (:func:`contact_plant`); ``estimator_settings``: the task's ``estimator``.
    """
    period = 1.0 / CONTROL_RATE_HZ
    tcp = tcp_transform(plan.recognised)
    max_duration = contact["max_duration"]
    reference, painting = reference_poses(
        plan,
        wall,
        CONTROL_RATE_HZ,
        float(contact["approach_s"]),
        float(contact["duration_scale"]),
        None if max_duration is None else float(max_duration),
    )
    start = reference[0].copy()
    start[0, 3] += float(contact["standoff"])  # start off the wall; the force loop brings the roller on it
    cases = [
        ContactCase(
            contact_plant(truth, plan.tool, wall, contact, seed),
            controller,
            ExternalForceEstimator(model, tcp, period, **estimator_settings),
            ControlSetup(model, SwivelIK(model), tcp, plan.path.parameters.swivel, plan.path.branch, period),
            start,
        )
        for model, controller in controllers
    ]
    steps = tqdm(
        range(reference.shape[0]), desc="contact simulation", unit="step", leave=False, mininterval=2.0
    )
    return simulate_contacts(cases, reference, painting, progress=steps)


@dataclass
class ScoredRun:
    """One painting run and its score."""

    roller: str
    model: str
    """The controller's model: ``identified``, ``cad``, or ``position`` (comparison controller)."""
    feedback: str
    """``estimate``, ``sensor``, or ``none`` (a controller without force feedback)."""
    run: ContactRun
    forces: dict[str, np.ndarray]
    """Normal forces while painting (:func:`normal_force_table`)."""
    force_errors: list[dict[str, Any]]
    """Table IV rows: comparison, rms (N), rms_over_mean_pct (%)."""
    summary: dict[str, Any]
    """The ``painting_runs.csv`` row: coverage, tracking, mean forces, times."""

    @property
    def key(self) -> str:
        """``<roller>_<model>_<feedback>``: the run's name in metrics and files."""
        return f"{self.roller}_{self.model}_{self.feedback}"


def score_run(
    roller: str,
    model: str,
    feedback: str,
    plan: RollerPlan,
    run: ContactRun,
    desired_force: float | None,
    cutoff_hz: float,
    simulation_s: float,
) -> ScoredRun:
    """Table IV's force errors, the painted coverage and the path tracking of ``run``.

    ``simulation_s``: the run's share of the wall time its roller's runs took, stepped together (s).
    """
    forces = normal_force_table(run, desired_force, cutoff_hz)
    labels = {"roller": roller, "model": model, "feedback": feedback}
    errors = []
    for first, second in COMPARISONS:
        if first in forces and second in forces:  # no desired force: only estimated/measured
            rms, rms_over_mean_pct = force_errors(forces[first], forces[second])
            errors.append(
                {
                    **labels,
                    "comparison": f"{first}/{second}",
                    "rms": rms,
                    "rms_over_mean_pct": rms_over_mean_pct,
                }
            )
    in_contact = run.painting & (run.measured_force[:, 0] < IN_CONTACT_N)
    p, width = plan.path.parameters, plan.recognised.width
    coverage, painted = painted_fraction(
        run.actual[:, 1],
        run.actual[:, 2],
        in_contact,
        plan.tool.width,
        (p.y_start - width / 2, p.y_end + width / 2, p.z_lower, p.z_upper),
    )
    offset = run.actual[run.painting, 1:] - run.reference[run.painting, 1:]  # in the wall plane
    summary = {
        **labels,
        "coverage": coverage,
        # a gap between two stripes would leave an interior column (a vertical band)
        # unpainted; the outer 1 cm on each side follows the path's lateral tracking error
        "worst_interior_column_coverage": float(painted.mean(axis=0)[EDGE:-EDGE].min()),
        "worst_row_coverage": float(painted.mean(axis=1).min()),
        "tracking_rms_m": float(np.sqrt(np.mean(np.sum(offset**2, axis=1)))),
        "mean_measured_N": float(forces["measured"].mean()),
        "mean_estimated_N": float(forces["estimated"].mean()),
        "painting_s": float(run.painting.sum() * (run.t[1] - run.t[0])),
        "simulation_s": simulation_s,
    }
    return ScoredRun(roller, model, feedback, run, forces, errors, summary)
