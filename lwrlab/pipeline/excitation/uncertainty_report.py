"""The excitation report's answer to "is another motion worth it?": expected uncertainty before and after.

From the information already known (none, logs, a model) and the designed motion's (its base
regressor on the optimisation grid, weighed by the torque noise density), the expected standard
deviation of every base parameter before and after the motion, its torque effect
(:mod:`lwrlab.excitation.uncertainty`), which parameters stay poorly known, and, for a criterion aimed
at target motions, the expected torque std along them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.regressor import regressor
from lwrlab.excitation.known_information import KnownInformation, information_from_rows, torque_std
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.uncertainty import (
    POORLY_KNOWN_SHARE,
    ParameterUncertainty,
    parameter_uncertainty,
    workspace_torque_rms,
)
from lwrlab.io.target_motions import TargetMotion

DEFAULT_NOISE_DENSITY = 1e-5
"""N²·m²·s assumed when nothing says the sensors' noise: 0.1 N·m white noise at 1 kHz (the simulated
plant's default)."""


@dataclass(frozen=True)
class NextMotionReport:
    """Expected uncertainty before and after a designed motion."""

    parameters: ParameterUncertainty
    targets: pd.DataFrame | None
    """Per target and joint: torque std (N·m, RMS along the target) before and after; None: no target."""
    known: tuple[str, ...]
    """What was known before (empty: nothing)."""
    noise: str
    """Where the noise density came from."""

    def metrics(self) -> dict[str, float]:
        """Counts of poorly known parameters and, with targets, the mean target torque std (N·m)."""
        metrics = {
            "poorly_known_before": float(len(self.parameters.poorly_known(after=False))),
            "poorly_known_after": float(len(self.parameters.poorly_known(after=True))),
        }
        if self.targets is not None:
            for when in ("before", "after"):
                values = self.targets[f"torque_std_{when}"].to_numpy()
                if np.all(np.isfinite(values)):
                    metrics[f"target_torque_std_{when}"] = float(np.mean(values))
        return metrics

    def lines(self) -> list[str]:
        """The report's section (Markdown)."""
        table = self.parameters.table()
        shown = table.drop(columns=["poorly_known_after"]).copy()
        shown.insert(
            len(shown.columns), "poorly known after", np.where(table["poorly_known_after"], "yes", "")
        )
        before, after = self.parameters.poorly_known(after=False), self.parameters.poorly_known(after=True)
        known = "; ".join(self.known) if self.known else "nothing (a motion designed alone)"
        lines = [
            "## Is another motion worth it? Expected uncertainty of the base parameters",
            "",
            f"Known before this motion: {known}. Torque noise density from {self.noise}. Values: the "
            "robot's CAD base parameters; torque effect: the RMS torque (N·m) a one-σ error of the "
            "parameter makes over random states within the limits; poorly known: a torque effect above "
            f"{100 * POORLY_KNOWN_SHARE:g} % of the robot's torque RMS there "
            f"({self.parameters.threshold:.3g} N·m).",
            "",
            shown.to_markdown(floatfmt=".3g"),
            "",
            f"Poorly known before: {len(before)} of {len(table)}; after this motion: {len(after)}"
            + (f" ({', '.join(after)})." if after else "."),
        ]
        if after:
            lines.append(
                "These stay poorly known: another motion designed for them "
                "(`task.known_logs=[<this motion's log>]`, or `task.known_model=<the model identified from "
                "it>`) would help, or they matter little where the model will be used (see the target "
                "motions)."
            )
        else:
            lines.append("Every base parameter will be well known: another motion would add little.")
        if self.targets is not None:
            lines += [
                "",
                "### Along the target motions: expected std of the predicted torque (N·m, RMS along each)",
                "",
                self.targets.reset_index().to_markdown(index=False, floatfmt=".3g"),
            ]
        return lines

    def write(self, output_dir: Path, robot_name: str = "") -> Path:
        """``parameter_uncertainty.csv`` and its figure ``parameter_uncertainty.png`` (and
        ``target_torque_std.csv``) in ``output_dir``."""
        from lwrlab.figures.excitation import uncertainty_figure

        path = output_dir / "parameter_uncertainty.csv"
        table = self.parameters.table()
        table.to_csv(path)
        title = "base parameters before and after this motion"
        uncertainty_figure(
            self.parameters.names,
            table["torque_effect_before"].to_numpy(),
            table["torque_effect_after"].to_numpy(),
            self.parameters.threshold,
            output_dir / "parameter_uncertainty.png",
            f"{robot_name}: {title}" if robot_name else title.capitalize(),
        )
        if self.targets is not None:
            self.targets.to_csv(output_dir / "target_torque_std.csv")
        return path


def plant_noise_density(cfg: Any) -> tuple[np.ndarray | None, str]:
    """The simulated plant's torque noise density per joint (σ_τ²/rate, N²·m²·s); None for another plant."""
    from omegaconf import OmegaConf

    std = OmegaConf.select(cfg, "plant.torque_noise_std", default=None)
    rate = OmegaConf.select(cfg, "measurement.rate_hz", default=None)
    if std is None or rate is None:
        return None, ""
    values = np.asarray(OmegaConf.to_container(std) if OmegaConf.is_config(std) else std, dtype=float)
    return values**2 / float(rate), f"the simulated plant (σ_τ = {values.max():g} N·m at {float(rate):g} Hz)"


def next_motion_report(
    problem: ExcitationProblem,
    coefficients: np.ndarray,
    known: KnownInformation | None,
    noise_density: np.ndarray | None,
    noise_source: str,
    targets: list[TargetMotion],
) -> NextMotionReport:
    """Expected uncertainty before and after the motion of ``coefficients`` (and along ``targets``).

    The noise density is the known information's when there is some, else ``noise_density`` (else
    :data:`DEFAULT_NOISE_DENSITY`).
    """
    robot, base = problem.robot, problem.base
    if known is not None:
        density, noise_source = known.noise_density, known.noise_source
    elif noise_density is not None:
        density = np.broadcast_to(np.asarray(noise_density, dtype=float), (robot.n_joints,))
    else:
        density = np.full(robot.n_joints, DEFAULT_NOISE_DENSITY)
        noise_source = f"no measurement (assumed {DEFAULT_NOISE_DENSITY:g} N²·m²·s: 0.1 N·m at 1 kHz)"
    q, dq, ddq = (b @ coefficients for b in problem.bases)
    rows = base.base_regressor(regressor(robot, q, dq, ddq))
    before = np.zeros((base.count, base.count)) if known is None else known.information
    after = before + information_from_rows(rows, problem.rate_hz, density)
    values = base.base_values(robot.parameters)
    uncertainty = parameter_uncertainty(
        base.names, values, before, after, problem.scales, workspace_torque_rms(robot)
    )
    table = None
    if targets:
        frames = []
        for motion in targets:
            thinned = motion.thinned(2000)
            w_target = base.base_regressor(regressor(robot, thinned.q, thinned.dq, thinned.ddq))
            frames.append(
                pd.DataFrame(
                    {
                        "target": motion.name,
                        "joint": np.arange(1, robot.n_joints + 1),
                        "torque_std_before": torque_std(before, w_target, robot.n_joints, problem.scales),
                        "torque_std_after": torque_std(after, w_target, robot.n_joints, problem.scales),
                    }
                )
            )
        table = pd.concat(frames).set_index(["target", "joint"])
    return NextMotionReport(uncertainty, table, () if known is None else known.sources, noise_source)
