"""The monitoring scenario: a simulated LWR4 in MuJoCo, identified from its logs, then pushed and struck.

:func:`write_scenario` writes, in a folder, what a user of ``task=monitor`` has on a real robot, plus
the truth a real robot never gives:

- ``identification.parquet`` and ``validation.parquet``: contact-free logs (the shipped optimal
  exciting motion and the 20 s validation motion) and ``identified_model.yaml``, the model
  identified from them as ``task=identification plant=log`` does;
- ``monitored.parquet``: a long log of chained multi-sine motions, contact-free for
  ``contact_free_s`` seconds, then with pushes (5–50 N, 50–500 ms) and impacts on links 3–7 every
  ``spacing`` seconds for ``contact_s`` seconds;
- ``monitored_contacts.csv`` (each force: start, end, peak, kind, link, point, force vector) and
  ``monitored_truth.parquet`` (``t``, the true external joint torque ``tau_ext1…``, the force).

Used by ``benchmarks/monitor.py`` and the slow tests; ``task=monitor`` reads the files as any logs::

    lwrlab task=monitor plant=log task.model=<folder>/identified_model.yaml \\
      'task.calibration_paths=[<folder>/identification.parquet,<folder>/validation.parquet]' \\
      'data.paths=[<folder>/monitored.parquet]' task.truth_contacts=<folder>/monitored_contacts.csv
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.io.artifacts import save_identified_model
from lwrlab.io.logs import write_log
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.pushed_arm import PushedArm, chained, random_forces
from lwrlab.plants.simulation import perturbed_robot
from lwrlab.trajectory.core import Trajectory

RATE_HZ = 1000.0
"""Control and sensor rate of the scenario (Hz)."""
SEGMENT_S = 20.0
"""Duration of each multi-sine motion of the monitored log (s)."""
CONTACT_LINKS = (3, 4, 5, 6, 7)
"""Links pushed and struck."""
PD_GAINS = (
    (2000.0, 2000.0, 1000.0, 1000.0, 300.0, 300.0, 100.0),
    (100.0, 100.0, 50.0, 50.0, 15.0, 15.0, 5.0),
)
"""Joint PD gains of the scenario's controller (N·m/rad, N·m·s/rad)."""


@dataclass(frozen=True)
class ScenarioFiles:
    """Where the scenario's files are."""

    folder: Path
    identification: Path
    validation: Path
    model: Path
    monitored: Path
    contacts: Path
    truth: Path
    torque_noise_std: float
    """σ_τ of the simulated sensors (N·m)."""
    contact_free_s: float
    """Contact-free time at the monitored log's start (s)."""


def _motion(robot: RobotModel, segments: int, seed: int) -> Trajectory:
    """``segments`` multi-sines of :data:`SEGMENT_S`, each from and to rest at the range's middle."""
    return chained(
        [
            build(
                "trajectory", "multisine", duration=SEGMENT_S, harmonics=8, seed=seed + i, limit_fraction=0.6
            ).sample(robot, RATE_HZ)
            for i in range(segments)
        ]
    )


def identify_logs(
    model_path: Path, fit: Sequence[Path], check: Sequence[Path], overrides: Sequence[str] = ()
) -> Path:
    """Identify a robot from logs as ``lwrlab task=identification plant=log <overrides>`` does; write
    its ``identified_model.yaml`` at ``model_path``."""
    from hydra import compose, initialize_config_module

    import lwrlab.conf  # noqa: F401  (registers the schemas the YAML files link)
    from lwrlab.pipeline.config_nodes import resolved_mapping
    from lwrlab.pipeline.identification import identify_configured
    from lwrlab.resources import CONFIG_PACKAGE

    with initialize_config_module(config_module=CONFIG_PACKAGE, version_base=None):
        cfg = compose(
            "config",
            overrides=[
                "task=identification",
                "plant=log",
                *overrides,
                f"data.paths=[{','.join(map(str, fit))}]",
                f"data.validation_paths=[{','.join(map(str, check))}]",
            ],
        )
    report = identify_configured(cfg)
    return save_identified_model(report.identified, resolved_mapping(cfg.robot, "robot"), model_path)


def write_scenario(
    folder: Path,
    *,
    seed: int = 0,
    contact_free_s: float = 600.0,
    contact_s: float = 120.0,
    spacing: float = 2.5,
    torque_noise_std: float = 0.1,
    encoder_noise_std: float = 1.7e-5,
) -> ScenarioFiles:
    """Simulate and write the scenario's logs, truth and identified model in ``folder`` (see the module)."""
    folder.mkdir(parents=True, exist_ok=True)
    cad = build("robot", "kuka_lwr4")
    truth = perturbed_robot(cad, 0.1, 0.2, np.random.default_rng(seed))
    kp, kd = PD_GAINS
    arm = PushedArm(
        truth,
        cad,
        kp=kp,
        kd=kd,
        substeps=2,
        torque_noise_std=torque_noise_std,
        encoder_noise_std=encoder_noise_std,
        seed=seed,
    )
    contact_free = {
        "identification": build("trajectory", "optimal").sample(cad, RATE_HZ),
        "validation": build("trajectory", "multisine_validation").sample(cad, RATE_HZ),
    }
    paths = {}
    for name, motion in contact_free.items():
        paths[name] = write_log(arm.run(motion, [], name).measurement, folder / f"{name}.parquet")
    model = identify_logs(folder / "identified_model.yaml", [paths["identification"]], [paths["validation"]])
    segments = int(np.ceil((contact_free_s + contact_s) / SEGMENT_S))
    motion = _motion(cad, segments, seed=100 * seed + 7)
    forces = random_forces(
        cad,
        motion,
        np.random.default_rng(seed + 1),
        window=(contact_free_s, contact_free_s + contact_s),
        spacing=spacing,
        links=CONTACT_LINKS,
    )
    run = arm.run(motion, forces, "monitored")
    monitored = write_log(run.measurement, folder / "monitored.parquet")
    contacts = folder / "monitored_contacts.csv"
    run.contacts.to_csv(contacts, index=False)
    n = cad.n_joints
    truth_frame = pd.DataFrame(
        {
            "t": run.measurement.t,
            **{f"tau_ext{j + 1}": run.external_torque[:, j] for j in range(n)},
            **{f"force_{a}": run.force[:, i] for i, a in enumerate("xyz")},
        }
    )
    truth_path = folder / "monitored_truth.parquet"
    truth_frame.to_parquet(truth_path, index=False)
    return ScenarioFiles(
        folder,
        paths["identification"],
        paths["validation"],
        model,
        monitored,
        contacts,
        truth_path,
        torque_noise_std,
        contact_free_s,
    )
