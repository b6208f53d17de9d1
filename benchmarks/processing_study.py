"""Processing study: which default processing serves every data set, judged on motions not in the fit.

Data sets (each with a fit and a validation split that plays motions the fit has not seen):

- ``ours``: lwrlab's simulated LWR4 (truth known), the shipped optimal 10 s motion → the 20 s
  multisine validation motion, two seeds (two true robots);
- ``lwr4+ 2+3→1`` and ``lwr4+ 3→1,2``: the real KUKA LWR4+ runs of ``../shared/data/kuka_lwr4_hw``
  (read where they are; skipped without them);
- ``second sim``: another simulator's LWR4 (MuJoCo, smoothed Coulomb + viscous + a Stribeck bump,
  offsets, quantised encoders, a lagging recorded velocity; ``benchmarks/second_simulator.py``),
  fit on two motions, validated on a third.

Settings compared: the old processing (τ filtered at 10 Hz, regressor not; every 20th sample;
weighted least squares; no offset friction), the new defaults (the same zero-phase filter on τ
and every regressor column at an automatic cut-off, the positions filtered at the states' automatic
cut-off, predictions at the factor the fit logs choose, 5 × cut-off rows, velocity auto, offsets and
OLS for logs: the estimator is held at least squares here, the shipped estimator for logs, ``sdp``, was
chosen afterwards by ``benchmarks/model_study.py``), and one change at a time around the defaults (a
fixed cut-off is one filter on q, τ and W).
The score is ‖τ − τ̂‖/‖τ‖ (%) on the validation logs' raw torques at their logged samples; for
simulators also the base-parameter error.

    .venv/bin/python benchmarks/processing_study.py    # prints the table, writes outputs/processing_study.csv
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters  # noqa: E402
from lwrlab.dynamics.regressor import regressor  # noqa: E402
from lwrlab.identification.log_predictions import predict_measurement  # noqa: E402
from lwrlab.identification.state_cutoff import choose_state_factor  # noqa: E402
from lwrlab.io.logs import load_log  # noqa: E402
from lwrlab.model.robot import RobotModel  # noqa: E402
from lwrlab.pipeline.build import build  # noqa: E402
from lwrlab.plants.core import Measurement  # noqa: E402
from lwrlab.signal.processing import process  # noqa: E402

REAL_LWR4 = REPOSITORY.parent / "shared" / "data" / "kuka_lwr4_hw"
NPZ_MAP = {"t": "times", "q": "positions", "dq": "velocities", "tau": "torques"}


@dataclass
class DataSet:
    """Fit and validation measurements of one robot, with its truth when simulated."""

    name: str
    robot: RobotModel
    fit: list[Measurement]
    validation: list[Measurement]
    truth: np.ndarray | None = None
    """True standard parameters (simulators), in ``robot``'s parameter layout with (coulomb, viscous)."""
    recorded: bool = True
    """A log (offset friction and OLS by default) rather than our own simulator's in-memory data."""


@dataclass(frozen=True)
class Setting:
    """One processing and model choice."""

    name: str
    processing: dict[str, Any] = field(default_factory=dict)
    parallel: bool = True
    """Filter the regressor's columns like τ (False: the old processing, τ only)."""
    estimator: str = "default"
    """ols, wls, or default (ols for logs, wls for our simulator): least squares, as when this study
    chose the processing; the shipped estimator for logs is now ``sdp`` (``benchmarks/model_study.py``)."""
    offset: str = "default"
    """on, off, or default (on for logs)."""


DEFAULTS = {
    "cutoff_hz": "auto",
    "state_cutoff_hz": "auto",
    "order": 5,
    "difference_accuracy": 2,
    "trim_s": 0.2,
    "rate_hz": None,
    "velocity": "auto",
}
OLD = {
    "cutoff_hz": 10.0,
    "state_cutoff_hz": None,
    "order": 5,
    "difference_accuracy": 2,
    "trim_s": 0.2,
    "velocity": "differentiated",
}
SETTINGS = [
    Setting(
        "τ-only filter 10 Hz, every 20th sample, wls, no offset",
        {**OLD, "rate_hz": None},
        parallel=False,
        estimator="wls",
        offset="off",
    ),
    Setting("defaults", DEFAULTS),
    Setting("states at the rows' cut-off (one filter)", {**DEFAULTS, "state_cutoff_hz": None}),
    Setting("cut-off 10 Hz", {**DEFAULTS, "cutoff_hz": 10.0, "state_cutoff_hz": None}),
    Setting("cut-off 4 Hz", {**DEFAULTS, "cutoff_hz": 4.0, "state_cutoff_hz": None}),
    Setting("cut-off 2 Hz", {**DEFAULTS, "cutoff_hz": 2.0, "state_cutoff_hz": None}),
    Setting("no decimation", {**DEFAULTS, "rate_hz": 1e6}),
    Setting("τ-only filter", DEFAULTS, parallel=False),
    Setting("velocity logged", {**DEFAULTS, "velocity": "logged"}),
    Setting("velocity differentiated", {**DEFAULTS, "velocity": "differentiated"}),
    Setting("estimator wls", DEFAULTS, estimator="wls"),
    Setting("estimator ols", DEFAULTS, estimator="ols"),
    Setting("no offset friction", DEFAULTS, offset="off"),
    Setting("offset friction", DEFAULTS, offset="on"),
]


def _old_rows(data: Any, regress: Callable[..., np.ndarray], every: int) -> tuple[np.ndarray, np.ndarray]:
    """The old processing: filtered τ against the unfiltered regressor, one sample in ``every`` of the log."""
    thinned = int(data.source_index[1] - data.source_index[0])  # log samples per working sample
    rows = data.index[:: max(1, every // thinned)]
    return regress(data.q[rows], data.dq[rows], data.ddq[rows]), data.tau[rows].ravel()


def evaluate(data_set: DataSet, setting: Setting) -> dict[str, float]:
    """Fit ``data_set`` with ``setting``; validation error (%), base-parameter error (%) when known."""
    if setting.processing.get("velocity") == "logged" and any(
        m.dq is None for m in data_set.fit + data_set.validation
    ):
        return {"validation_%": float("nan")}  # no logged velocities in this data set
    offset = setting.offset == "on" or (setting.offset == "default" and data_set.recorded)
    robot = (
        replace(data_set.robot, friction_terms=("coulomb", "viscous", "offset")) if offset else data_set.robot
    )
    base: BaseParameters = compute_base_parameters(robot)
    processing = dict(setting.processing)
    if not setting.parallel:  # the old pipeline: 1 kHz logs decimated by 20 samples, whatever their rate
        processing["rate_hz"] = 1e6

    def regress(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        return base.base_regressor(regressor(robot, q, dq, ddq))

    started = time.perf_counter()
    blocks, processed = [], []
    for measurement in data_set.fit:
        data = process(measurement.t, measurement.q, measurement.tau, measurement.dq, **processing)
        processed.append(data)
        blocks.append(data.rows(regress) if setting.parallel else _old_rows(data, regress, 20))
    w = np.vstack([b[0] for b in blocks])
    tau = np.concatenate([b[1] for b in blocks])
    kind = setting.estimator if setting.estimator != "default" else ("ols" if data_set.recorded else "wls")
    estimator = (
        build("estimator", "ols") if kind == "ols" else build("estimator", "wls", n_joints=robot.n_joints)
    ).fit(w, tau)
    # predictions filter the states as an identification does: at the factor the fit logs choose
    states = choose_state_factor(robot, base, estimator.phi_, data_set.fit, processed, processing)
    processing = processing if states is None else states.processing(processing)
    row = {
        "validation_%": float(
            np.mean(
                [
                    100 * predict_measurement(robot, base, estimator.phi_, m, processing).relative_error
                    for m in data_set.validation
                ]
            )
        )
    }
    row["seconds"] = time.perf_counter() - started
    if data_set.truth is not None:
        truth = np.concatenate([data_set.truth, np.zeros(robot.n_joints)]) if offset else data_set.truth
        true_base = base.base_values(truth)
        row["base_error_%"] = float(
            100 * np.linalg.norm(estimator.phi_ - true_base) / np.linalg.norm(true_base)
        )
        coulomb = [base.names.index(f"FC{j}") for j in range(1, robot.n_joints + 1)]
        row["coulomb_max_error_%"] = float(
            100 * np.max(np.abs(estimator.phi_[coulomb] / true_base[coulomb] - 1))
        )
    return row


def simulated_lwr4(seed: int) -> tuple[Any, RobotModel, Any]:
    """Our simulated LWR4 as ``task=identification`` configures it with ``seed``: config, robot, plant."""
    from hydra import compose, initialize_config_dir
    from hydra.utils import instantiate

    import lwrlab.conf  # noqa: F401  (registers the schemas the YAML files link)

    with initialize_config_dir(config_dir=str(REPOSITORY / "conf"), version_base=None):
        cfg = compose(
            "config", overrides=["task=identification", f"seed={seed}", "plant.show_progress=false"]
        )
    robot = instantiate(cfg.robot)
    return cfg, robot, instantiate(cfg.plant)(robot=robot)


def ours(seed: int) -> DataSet:
    """lwrlab's simulated LWR4 with the shipped optimal motion and the 20 s validation motion."""
    from hydra.utils import instantiate

    cfg, robot, plant = simulated_lwr4(seed)
    fit = plant.measure(instantiate(cfg.trajectory).sample(robot, cfg.measurement.rate_hz))
    validation = plant.measure(instantiate(cfg.validation).sample(robot, cfg.measurement.rate_hz))
    return DataSet(
        f"ours (seed {seed})", robot, [fit], [validation], truth=plant.truth.robot.parameters, recorded=False
    )


def real_lwr4_runs() -> tuple[RobotModel, dict[int, Measurement]] | None:
    """The URDF robot and the three real LWR4+ runs by number, or None (said) without ../shared."""
    if not (REAL_LWR4 / "measurements_1.npz").is_file():
        print(f"skipping the real LWR4+ runs: not found at {REAL_LWR4}")
        return None
    robot = build("robot", "urdf", path=str(REAL_LWR4 / "kuka_lwr4.urdf"))
    runs = {
        i: load_log(
            REAL_LWR4 / f"measurements_{i}.npz", 7, column_map=NPZ_MAP, limits=robot.limits
        ).to_measurement()
        for i in (1, 2, 3)
    }
    return robot, runs


def real_lwr4() -> list[DataSet]:
    """The real LWR4+ runs, two splits, if ../shared has them."""
    found = real_lwr4_runs()
    if found is None:
        return []
    robot, runs = found
    return [
        DataSet("lwr4+ 2+3→1", robot, [runs[2], runs[3]], [runs[1]]),
        DataSet("lwr4+ 3→1,2", robot, [runs[3]], [runs[1], runs[2]]),
    ]


def second_simulator(folder: Path) -> list[DataSet]:
    """The second simulator's logs (MuJoCo), written into ``folder``."""
    try:
        from benchmarks.second_simulator import write_logs
    except ImportError as error:
        print(f"skipping the second simulator: {error}")
        return []
    import yaml

    from plugins.robots.mdh import load_robot_yaml

    write_logs(folder, seed=0)
    robot = load_robot_yaml(REPOSITORY / "conf" / "robot" / "kuka_lwr4.yaml")

    def load(name: str) -> Measurement:
        return load_log(folder / f"{name}.npz", 7, column_map=NPZ_MAP, limits=robot.limits).to_measurement()

    names = (
        yaml.safe_load((folder / "splits.yaml").read_text()) if (folder / "splits.yaml").is_file() else None
    )
    splits = names or {
        "a+b→c": (["motion_a_1", "motion_b"], ["motion_c"]),
        "b→a": (["motion_b"], ["motion_a_1", "motion_a_2"]),
    }
    return [
        DataSet(f"second sim {key}", robot, [load(n) for n in fit], [load(n) for n in validation])
        for key, (fit, validation) in splits.items()
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=REPOSITORY / "outputs" / "processing_study.csv")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        data_sets = [ours(seed) for seed in args.seeds] + real_lwr4() + second_simulator(Path(folder))
        rows = []
        for data_set in data_sets:
            for setting in SETTINGS:
                result = evaluate(data_set, setting)
                rows.append({"data": data_set.name, "setting": setting.name, **result})
                print(
                    f"{data_set.name:22s} {setting.name:60s} "
                    + "  ".join(f"{k} {v:.4g}" for k, v in result.items()),
                    flush=True,
                )
    table = pd.DataFrame(rows)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.output, index=False)
    wide = table.pivot(index="setting", columns="data", values="validation_%").reindex(
        [s.name for s in SETTINGS]
    )
    print("\nvalidation ‖τ−τ̂‖/‖τ‖ (%) on motions not in the fit\n")
    print(wide.to_markdown(floatfmt=".3g"))
    if "base_error_%" in table:
        simulated = (
            table.dropna(subset=["base_error_%"])
            .pivot(index="setting", columns="data", values="base_error_%")
            .reindex([s.name for s in SETTINGS])
        )
        print("\nbase-parameter error ‖β̂ − β‖/‖β‖ (%), our simulator\n")
        print(simulated.to_markdown(floatfmt=".3g"))
    print(f"\nwritten {args.output}")


if __name__ == "__main__":
    main()
