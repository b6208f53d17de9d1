"""Simulated plant (config group ``plant``): the stand-in for a real robot.

The ground truth is the nominal (CAD) robot with every segment perturbed by ``parameter_spread``
(relative, physically consistent) and its friction by ``friction_spread``, drawn once from
``seed``. Executing a motion gives 1 kHz (the trajectory's rate) samples of encoder positions
(white noise ``encoder_noise_std`` rad, quantised to ``encoder_resolution`` rad) and joint torques
(white noise ``torque_noise_std`` N·m). Two modes:

- ``playback``: the robot follows the motion exactly; torques by inverse dynamics of the truth.
- ``closed_loop``: joint PD + gravity compensation from the nominal model tracks the motion; the
  true dynamics are integrated with Pinocchio's ABA at ``substeps`` × the sampling rate.

A ``tool`` (a :class:`lwrlab.tools.model.Tool`, or its 10 flange-frame parameters) is attached to the
true robot's flange: it changes the last segment (:func:`lwrlab.model.payload.attach_payload`).
``with_tool`` gives the same robot (same truth, same noise stream) carrying another tool.

``measure`` returns a :class:`~lwrlab.plants.Measurement`; the truth is kept in ``truth`` for scoring.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, PlantTruth
from lwrlab.plants.simulation import encoder_reading, perturbed_robot, playback_torques, track_closed_loop
from lwrlab.trajectory.core import Trajectory

MODES = ("playback", "closed_loop")


class SimulatedPlant:
    """A simulated robot with perturbed parameters, friction and sensor noise.

    Parameters
    ----------
    robot : the nominal robot (CAD); the truth is drawn around it.
    mode : ``"playback"`` or ``"closed_loop"``.
    parameter_spread : relative spread of the segments' inertial parameters.
    friction_spread : relative spread of the friction values.
    torque_noise_std : torque-sensor noise σ_τ (N·m), scalar or per joint.
    encoder_noise_std : encoder noise σ_q (rad).
    encoder_resolution : quantisation step (rad), 0 for none.
    seed : seed of the truth and of the noise.
    kp, kd : PD gains (N·m/rad, N·m·s/rad) per joint for ``closed_loop``.
    substeps : integration steps per sample for ``closed_loop``.
    show_progress : show a progress bar during closed-loop simulation.
    tool : a tool fixed to the flange (``Tool`` or its 10 flange-frame parameters), None for none.
    """

    def __init__(
        self,
        robot: RobotModel,
        mode: str = "playback",
        parameter_spread: float = 0.1,
        friction_spread: float = 0.2,
        torque_noise_std: float | Sequence[float] = 0.1,
        encoder_noise_std: float = 1.7e-5,
        encoder_resolution: float = 0.0,
        seed: int = 0,
        kp: Sequence[float] | None = None,
        kd: Sequence[float] | None = None,
        substeps: int = 4,
        show_progress: bool = True,
        tool: Any = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown plant mode {mode!r}; valid modes: {list(MODES)}")
        self.nominal = robot
        self.mode = mode
        self.torque_noise_std = np.broadcast_to(np.asarray(torque_noise_std, dtype=float), (robot.n_joints,))
        self.encoder_noise_std = encoder_noise_std
        self.encoder_resolution = encoder_resolution
        self.substeps = substeps
        self.show_progress = show_progress
        self.kp = np.asarray(kp if kp is not None else np.full(robot.n_joints, 2000.0), dtype=float)
        self.kd = np.asarray(kd if kd is not None else np.full(robot.n_joints, 60.0), dtype=float)
        self._rng = np.random.default_rng(seed)
        self._unloaded = perturbed_robot(robot, parameter_spread, friction_spread, self._rng)
        self._truth = PlantTruth(attach_payload(self._unloaded, _tool_parameters(tool)))
        self.tool = tool
        self._settings = {
            "mode": mode,
            "parameter_spread": parameter_spread,
            "friction_spread": friction_spread,
            "torque_noise_std": self.torque_noise_std.tolist(),
            "encoder_noise_std": encoder_noise_std,
            "encoder_resolution": encoder_resolution,
            "seed": seed,
        }

    @property
    def truth(self) -> PlantTruth:
        """The true robot (for scoring only)."""
        return self._truth

    def with_tool(self, tool: Any) -> SimulatedPlant:
        """The same robot (truth, settings, noise stream) carrying ``tool`` instead (None: unloaded)."""
        plant = copy.copy(self)
        plant._truth = PlantTruth(attach_payload(self._unloaded, _tool_parameters(tool)))
        plant.tool = tool
        return plant

    def measure(self, trajectory: Trajectory) -> Measurement:
        """Execute ``trajectory`` and return noisy sensor samples at its rate."""
        robot = self._truth.robot
        if self.mode == "playback":
            q, tau = trajectory.q, playback_torques(robot, trajectory)
        else:
            steps = tqdm(
                range(trajectory.t.shape[0]),
                desc="closed-loop simulation",
                unit="step",
                disable=not self.show_progress,
                leave=False,
            )
            q, _, tau = track_closed_loop(
                robot, self.nominal, trajectory, self.kp, self.kd, self.substeps, progress=steps
            )
        return Measurement(
            t=trajectory.t.copy(),
            q=encoder_reading(q, self.encoder_noise_std, self.encoder_resolution, self._rng),
            tau=tau + self.torque_noise_std * self._rng.normal(size=tau.shape),
            metadata={"source": "simulated", "rate_hz": trajectory.rate_hz, **self._settings},
        )


def _tool_parameters(tool: Any) -> np.ndarray | None:
    """The 10 flange-frame parameters of a tool (a ``Tool`` or an array), None for no tool."""
    if tool is None:
        return None
    return np.asarray(getattr(tool, "parameters", tool), dtype=float)
