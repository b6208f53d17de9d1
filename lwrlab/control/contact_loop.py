"""The 1 kHz contact simulation loop of Fig. 8: sensors → estimator → controller → plant.

The plant is the MuJoCo contact plant (:class:`lwrlab.plants.mujoco_contact.MujocoContactPlant`),
the estimator eq. (14)'s (:class:`ExternalForceEstimator`), the controller any object of the
:class:`PaintingController` protocol (plugins in ``plugins/controllers/``).

The runs of a painting task that share a path (controller model × force feedback × controller)
are stepped together, one period of all of them per pass (:func:`simulate_contacts`): MuJoCo and
Pinocchio are called once per run, but the numpy around them — friction, filters, force loops, the
IK lookup of the displaced path, the PD law, the sensor readings — runs once on stacked (R, ·)
arrays, so its cost is shared by the R runs. Controllers deriving from
:class:`~lwrlab.control.cartesian_offset.OffsetTrackingController` (both painting controllers) are
stepped as one batch; any other controller runs alone inside the batch. A single run is a batch of
one (:func:`simulate_contact`); each run of a batch equals that run simulated alone (tested).
``benchmarks/painting.py`` measures the loop against the per-sample loop it replaced and MuJoCo alone.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from lwrlab.control.cartesian_offset import OffsetTrackingBatch, OffsetTrackingController
from lwrlab.control.force_estimation import ExternalForceEstimator, ForceEstimatorBatch, StateEstimate
from lwrlab.control.joint_pd import ControlOutput, ControlSetup, JointPDGravity
from lwrlab.plants.contact_batch import ContactPlantBatch
from lwrlab.plants.mujoco_contact import MujocoContactPlant

__all__ = [
    "ContactCase",
    "ContactRun",
    "ControlOutput",
    "PaintingController",
    "simulate_contact",
    "simulate_contacts",
]


class PaintingController(Protocol):
    """A controller plugin (config group ``controller``)."""

    @property
    def uses_force_feedback(self) -> bool:
        """Whether a force loop closes on a measured or estimated force; such a controller takes a
        ``feedback`` argument (``estimate``: eq. 14, ``sensor``: the wall's sensor)."""
        ...

    @property
    def desired_force(self) -> np.ndarray | None:
        """(3,) F_d (N) the controller regulates, base axes; None without a force target."""
        ...

    def reset(self, setup: ControlSetup, q0: np.ndarray, reference: np.ndarray) -> None:
        """Prepare for a run starting at rest at ``q0`` (rad) along the tool poses ``reference`` (N, 4, 4).

        Knowing the whole reference lets a controller solve its IK in batches
        (:meth:`ControlSetup.path_ik`) instead of one pose per period.
        """
        ...

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        """Torques for period ``k`` (reference pose ``reference[k]``) from the estimated state and the
        wall sensor's force (N); the state's arrays are the caller's, valid during the call."""
        ...


@dataclass
class ContactRun:
    """One simulated painting run, sampled at the control rate (value object of the painting stage)."""

    t: np.ndarray
    """(N,) time (s)."""
    reference: np.ndarray
    """(N, 3) desired tool-centre-point position, the painting path (m)."""
    commanded: np.ndarray
    """(N, 3) reference + ΔP_c the inner loop tracked (m)."""
    actual: np.ndarray
    """(N, 3) true tool-centre-point position (m)."""
    estimated_wrench: np.ndarray
    """(N, 6) estimated wrench on the environment at the tool centre point, eq. (14) (N, N·m)."""
    measured_force: np.ndarray
    """(N, 3) force measured by the wall sensor (N)."""
    q: np.ndarray
    """(N, N_J) true joint positions (rad)."""
    q_desired: np.ndarray
    """(N, N_J) joint reference (rad)."""
    tau: np.ndarray
    """(N, N_J) commanded torques (N·m)."""
    painting: np.ndarray
    """(N,) True during the painting path (False during the approach)."""
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ContactCase:
    """One run of a batch: what it is simulated with."""

    plant: MujocoContactPlant
    """The plant (the true robot and tool, the wall), its own per run."""
    controller: PaintingController
    estimator: ExternalForceEstimator
    """Eq. (14) with the controller's model."""
    setup: ControlSetup
    """The controller's model, IK and path settings."""
    start: np.ndarray | None = None
    """Tool pose (4, 4) the robot starts at rest at; None: the first reference pose."""


class _Alone:
    """A controller without a batched law as a batch of one (rows of one run)."""

    def __init__(self, controller: PaintingController) -> None:
        self.controller = controller

    def reset(self, setups: Sequence[ControlSetup], q0: np.ndarray, reference: np.ndarray) -> None:
        self.controller.reset(setups[0], q0[0], reference)

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        output = self.controller.command(k, StateEstimate(*(value[0] for value in state)), measured_force[0])
        return ControlOutput(*(np.asarray(value)[None] for value in output))


_Batch = OffsetTrackingBatch | _Alone


class _Groups:
    """Controller batches over disjoint rows of the runs, their decisions put back in run order."""

    def __init__(self, groups: list[tuple[list[int], _Batch]], n_runs: int) -> None:
        self.groups, self.n_runs = [(np.array(rows), batch) for rows, batch in groups], n_runs

    def reset(self, setups: Sequence[ControlSetup], q0: np.ndarray, reference: np.ndarray) -> None:
        for rows, batch in self.groups:
            batch.reset([setups[r] for r in rows], q0[rows], reference)

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        tau, q_desired = np.empty_like(state.q), np.empty_like(state.q)
        commanded = np.empty((self.n_runs, 3))
        for rows, batch in self.groups:
            output = batch.command(k, StateEstimate(*(value[rows] for value in state)), measured_force[rows])
            tau[rows], commanded[rows], q_desired[rows] = output
        return ControlOutput(tau, commanded, q_desired)


def _batch_controllers(controllers: Sequence[PaintingController]) -> _Batch | _Groups:
    """All offset-tracking controllers in one batch, every other one alone."""
    laws = {r: c.law() for r, c in enumerate(controllers) if isinstance(c, OffsetTrackingController)}
    groups: list[tuple[list[int], _Batch]] = []
    if laws:
        groups.append((list(laws), OffsetTrackingBatch(list(laws.values()))))
    groups += [([r], _Alone(c)) for r, c in enumerate(controllers) if r not in laws]
    if len(groups) == 1:  # one batch of every run in order: its decisions need no reordering
        return groups[0][1]
    return _Groups(groups, len(controllers))


def simulate_contacts(
    cases: Sequence[ContactCase],
    reference: np.ndarray,
    painting: np.ndarray,
    progress: Iterable[int] | None = None,
) -> list[ContactRun]:
    """Run R cases over the same reference tool poses (N, 4, 4), one period of every case per pass.

    Each robot starts at rest at the joint solution of its case's ``start`` (default the first
    reference pose), held by its controller model's gravity compensation; ``painting`` (N,) marks
    the samples of the painting path. ``progress`` iterates over ``range(N)`` (e.g. a progress bar).
    Returns one :class:`ContactRun` per case, in order.
    """
    if not cases:
        raise ValueError("no contact case to simulate")
    n, n_runs = reference.shape[0], len(cases)
    setups = [case.setup for case in cases]
    q0 = np.array(
        [case.setup.joint_reference(reference[0] if case.start is None else case.start) for case in cases]
    )
    controllers = _batch_controllers([case.controller for case in cases])
    controllers.reset(setups, q0, reference)
    plants = ContactPlantBatch([case.plant for case in cases])
    # each controller's model holds its arm at rest at the start
    gravity = JointPDGravity([setup.robot for setup in setups], 0.0, 0.0, setups[0].period).gravity(q0)
    sensors = plants.reset(q0, gravity)
    estimators = ForceEstimatorBatch([case.estimator for case in cases])
    estimators.reset(sensors.q)
    n_joints = q0.shape[1]
    # sample-major: each period's records of all runs are one contiguous block
    commanded, actual, measured_force = (np.empty((n, n_runs, 3)) for _ in range(3))
    wrench = np.empty((n, n_runs, 6))
    q, q_desired, tau = (np.empty((n, n_runs, n_joints)) for _ in range(3))
    update, command, step = estimators.update, controllers.command, plants.step  # bound once: 1 kHz loop
    for k in progress if progress is not None else range(n):
        state = update(sensors.q, sensors.tau)
        decision = command(k, state, sensors.wall_force)
        commanded[k], actual[k], measured_force[k] = (
            decision.commanded_position,
            plants.tcp_position,
            sensors.wall_force,
        )
        wrench[k], q[k], q_desired[k], tau[k] = state.wrench, sensors.q_true, decision.q_desired, decision.tau
        sensors = step(decision.tau)
    t, positions, painting = np.arange(n) * setups[0].period, reference[:, :3, 3], np.asarray(painting, bool)
    return [
        ContactRun(
            t=t.copy(),
            reference=positions.copy(),
            commanded=commanded[:, r],
            actual=actual[:, r],
            estimated_wrench=wrench[:, r],
            measured_force=measured_force[:, r],
            q=q[:, r],
            q_desired=q_desired[:, r],
            tau=tau[:, r],
            painting=painting.copy(),
        )
        for r in range(n_runs)
    ]


def simulate_contact(
    plant: MujocoContactPlant,
    controller: PaintingController,
    estimator: ExternalForceEstimator,
    setup: ControlSetup,
    reference: np.ndarray,
    painting: np.ndarray,
    start: np.ndarray | None = None,
    progress: Iterable[int] | None = None,
) -> ContactRun:
    """One run over the reference tool poses (N, 4, 4): :func:`simulate_contacts` of one case."""
    return simulate_contacts(
        [ContactCase(plant, controller, estimator, setup, start)], reference, painting, progress
    )[0]
