"""The optimal exciting motion (config group ``trajectory``, option ``optimal``): Katsumata et al. §III.

A motion source that, asked for a motion for a robot, either

* loads a motion optimised earlier (``from_file``: an ``exciting_motion.yaml`` written by
  ``lwrlab task=excitation``) when it was made for this robot and duration, or
* solves the excitation problem (criterion + constraints of eq. (10)–(11) + parameterisation) with
  the configured optimizer,

then checks every constraint against the robot's true limits on the 1 kHz resampling (or whatever
rate is asked) before handing the motion out.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from typing import Any

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.excitation.constraints import ConstraintSettings
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.known_information import KnownInformation
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.solver import ExcitationResult, SlsqpOptimizer, check_motion, check_motion_at
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory
from lwrlab.trajectory.parameterisation import LinearParameterisation

log = logging.getLogger(__name__)


class OptimalExcitingMotion:
    """Optimise (or load) the exciting motion of a robot.

    Every setting is required: conf/trajectory/optimal.yaml gives their values.

    Parameters
    ----------
    parameterisation : factory ``f(duration=…, coefficients=None) -> LinearParameterisation`` (a
        ``_partial_`` config: the duration is this motion's, the coefficients what the optimiser finds).
    criterion : the criterion plugin (config group ``criterion``).
    optimizer : the solver (config group ``optimizer``), with ``solve(problem) -> ExcitationResult``.
    duration : T_F (s).
    constraints : keyword arguments of :class:`~lwrlab.excitation.constraints.ConstraintSettings`.
    rate_hz : optimisation grid rate (Hz).
    window_s : constraint aggregation window (s).
    coulomb_smoothing : ε (rad/s) of the smooth Coulomb columns during the optimisation.
    from_file : an exciting-motion file to use when it matches the robot and the duration: a path of
        the user's, or ``pkg://<package>/<path>`` for one shipped inside a package
        (:func:`lwrlab.resources.resolve_data_path`).
    """

    def __init__(
        self,
        *,
        parameterisation: Callable[..., LinearParameterisation],
        criterion: Criterion,
        optimizer: SlsqpOptimizer,
        duration: float,
        constraints: Mapping[str, Any],
        rate_hz: float,
        window_s: float,
        coulomb_smoothing: float | None,
        from_file: str | None,
    ) -> None:
        self.parameterisation = parameterisation
        self.criterion = criterion
        self.optimizer = optimizer
        self.duration = float(duration)
        self.constraints = ConstraintSettings(**dict(constraints))
        self.rate_hz = rate_hz
        self.window_s = window_s
        self.coulomb_smoothing = coulomb_smoothing
        self.from_file = from_file

    def bare_parameterisation(self, duration: float) -> LinearParameterisation:
        """The parameterisation of a ``duration`` (s) motion, without coefficients (what is optimised)."""
        return self.parameterisation(duration=duration, coefficients=None)

    def problem(
        self, robot: RobotModel, base: BaseParameters | None = None, known: KnownInformation | None = None
    ) -> ExcitationProblem:
        """The excitation problem for ``robot`` with these settings (``base`` computed if None), its
        criterion conditioned on the ``known`` information if given."""
        return ExcitationProblem(
            robot,
            self.bare_parameterisation(self.duration),
            self.criterion,
            self.constraints,
            rate_hz=self.rate_hz,
            window_s=self.window_s,
            base=base,
            coulomb_smoothing=self.coulomb_smoothing,
            known=known,
        )

    def optimise(
        self, robot: RobotModel, base: BaseParameters | None = None, known: KnownInformation | None = None
    ) -> tuple[LinearParameterisation, ExcitationResult, ExcitationProblem]:
        """Solve the excitation problem; the motion (with coefficients), the result and the problem.

        ``base``: the robot's base parameters, when a caller optimising many motions has them;
        ``known``: the information already in hand, in those base parameters (the next motion is
        designed for what it leaves open). The source itself is left unchanged (no state kept between
        calls).
        """
        problem = self.problem(robot, base, known)
        result = self.optimizer.solve(problem)
        return problem.parameterisation.with_coefficients(result.coefficients), result, problem

    def _load(self, robot: RobotModel, from_file: str) -> LinearParameterisation | None:
        """The motion of ``from_file`` if it was made for this robot and duration, else None (logged).

        ``from_file`` may be a folder (a library of motions, as the shipped
        ``pkg://lwrlab/data/exciting_motions``): the first of its files made for this robot, criterion,
        duration and parameterisation is played; none: the motion is optimised.
        """
        from lwrlab.resources import resolve_data_path

        path = resolve_data_path(from_file)
        if path.is_dir():
            for candidate in sorted(path.glob("*.yaml")):
                motion = self._load_file(robot, str(candidate), quiet=True)
                if motion is not None:
                    return motion
            log.info("no motion in %s was made for %s with these settings: optimising", path, robot.name)
            return None
        return self._load_file(robot, str(path), quiet=False)

    def _load_file(self, robot: RobotModel, from_file: str, quiet: bool) -> LinearParameterisation | None:
        """The motion of one file if it was made for this robot and these settings, else None."""
        from lwrlab.io.exciting_motion import load_motion_description

        description = load_motion_description(from_file)
        provenance = description.get("provenance", {})
        made_for, criterion = provenance.get("robot"), provenance.get("criterion")
        bare = self.bare_parameterisation(float(description["duration"]))
        settings = {key: description.get(key) for key in bare.settings()}
        wanted = (robot.name, self.criterion.name, self.duration, bare.kind, bare.settings())
        found = (made_for, criterion, float(description["duration"]), description["kind"], settings)
        if found != wanted:
            if quiet:
                return None
            log.warning(
                "%s holds a motion for (robot, criterion, duration, parameterisation, settings) = %s, "
                "not %s: optimising instead",
                description["path"],
                found,
                wanted,
            )
            return None
        log.info("exciting motion loaded from %s", description["path"])
        return bare.with_coefficients(description["coefficients"])

    def _from_library(self) -> bool:
        from lwrlab.resources import resolve_data_path

        return bool(self.from_file) and resolve_data_path(str(self.from_file)).is_dir()

    def sample(self, robot: RobotModel, rate_hz: float) -> Trajectory:
        """The exciting motion at ``rate_hz`` (Hz), checked against every constraint at that rate.

        Sampling changes nothing on the source: what an optimisation found travels in the
        trajectory's metadata (``cost``), the motion in the trajectory itself.
        """
        motion = self._load(robot, self.from_file) if self.from_file else None
        checked = False
        if motion is not None and self._from_library():
            check = check_motion_at(robot, motion, self.constraints, rate_hz)
            if not check.passed:  # made for this robot's meshes, say, while only its spheres are at hand
                log.warning(
                    "the library's motion for %s fails this robot's check (%s): optimising instead",
                    robot.name,
                    check.describe(),
                )
                motion = None
            checked = motion is not None
        cost = None
        if motion is None:
            motion, result, _ = self.optimise(robot)
            cost = result.cost
        if not checked:
            check_motion(robot, motion, self.constraints, rate_hz)
        trajectory = motion.sample(robot, rate_hz)
        metadata = {
            **trajectory.metadata,
            "source": "optimal",
            "parameterisation": motion.kind,
            "criterion": self.criterion.name,
        }
        if cost is not None:
            metadata["cost"] = cost
        if self.from_file and cost is None:
            metadata["file"] = str(self.from_file)
        return Trajectory(
            t=trajectory.t, q=trajectory.q, dq=trajectory.dq, ddq=trajectory.ddq, metadata=metadata
        )
