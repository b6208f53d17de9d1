"""Model study: which estimator (and model) predicts the torques of motions the fit has not seen.

A user identifies once and uses the model on every other motion the robot makes, so every split
here validates on a motion unlike the fit's (plus, for reference, the two real splits that repeat or
mix the fit's motion). Data sets:

- ``lwr4+ a→b``: the real KUKA LWR4+ runs of ``../shared/data/kuka_lwr4_hw`` (skipped without them):
  2→3 (a new, faster motion), 3→1 and 3→2 (new, slower), 2+3→1 (seen), 2→1 (repeated);
- ``ours``: lwrlab's simulated LWR4 (truth known): the shipped optimal 10 s B-spline motion →
  the 20 s multisine validation motion (another kind), and a slower multisine (another speed);
- ``second sim``: another simulator's LWR4 (MuJoCo, smoothed Coulomb + Stribeck bump, offsets,
  quantised encoders, lagging velocities; ``benchmarks/second_simulator.py``): a+b→c and b→a;
- ``geared``: geared arms logged at the motors (``benchmarks/geared_arms.py``: a UR-like arm with
  currents, an industrial arm with a coupled wrist; LuGre friction growing with the load, rotor
  inertias, rests): a multisine with pauses → another multisine, and → point-to-point moves with
  stops. Read as lwrlab reads them (motor side → joint side), scored like the real logs.

Each setting is an estimator and a friction law: ``sign`` (the robot's, the paper's) or ``auto`` (the
law and the rotor-inertia columns chosen by block cross-validation, as ``plant=log`` does).

Every setting is processed with the defaults (one zero-phase filter on q, τ and every regressor
column at the automatic cut-off, decimation; offsets for logs). Scores: ‖τ − τ̂‖/‖τ‖ (%) at the
validation logs' samples as logged; the base-parameter error where the truth is known; the coverage
of the 95 % prediction interval on the validation logs; the fit's CPU time. The summary weighs the
worst new-motion split as much as the mean: ``score = (mean + worst) / 2``; the geared arms get a
summary of their own (their stops hold a friction torque no friction law of the regressor predicts,
which would make them every setting's worst split).

    .venv/bin/python benchmarks/model_study.py    # prints the tables, writes outputs/model_study.csv
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from benchmarks.processing_study import (  # noqa: E402
    DEFAULTS,
    real_lwr4_runs,
    second_simulator,
    simulated_lwr4,
)
from lwrlab.dynamics.base_parameters import compute_base_parameters  # noqa: E402
from lwrlab.dynamics.regressor import regressor  # noqa: E402
from lwrlab.identification.context import IdentificationContext  # noqa: E402
from lwrlab.identification.friction_choice import choose_friction  # noqa: E402
from lwrlab.identification.log_predictions import (  # noqa: E402
    LogPrediction,
    joint_coverage,
    predict_measurement,
)
from lwrlab.identification.prediction_error import FRICTION_DRIFT_PRIOR, drift_parameters  # noqa: E402
from lwrlab.model.friction_laws import drifting_terms  # noqa: E402
from lwrlab.model.robot import RobotModel  # noqa: E402
from lwrlab.pipeline.build import build  # noqa: E402
from lwrlab.pipeline.identification import prediction_interval  # noqa: E402
from lwrlab.plants.core import Measurement  # noqa: E402
from lwrlab.signal.processing import process  # noqa: E402


@dataclass
class Split:
    """One fit → validation split of one robot's measurements."""

    data: str
    name: str
    robot: RobotModel
    fit: list[Measurement]
    validation: list[Measurement]
    new_motion: bool
    """Whether the validation motion is unlike every fitted one (what the defaults are judged on)."""
    truth: np.ndarray | None = None
    """True standard parameters (simulators), in ``robot``'s layout."""


@dataclass(frozen=True)
class Setting:
    """An estimator and its settings (the plugin's YAML values, changed by ``overrides``)."""

    name: str
    estimator: str
    overrides: dict[str, Any] = field(default_factory=dict)
    friction: str = "sign"
    """``sign``: the robot's friction law (the paper's); ``auto``: ``conf/friction/auto.yaml``, the law
    and the rotor-inertia columns chosen on the fit rows by block cross-validation."""
    friction_drift: float = FRICTION_DRIFT_PRIOR
    """ρ of the prediction interval (``statistics.friction_drift``)."""


SETTINGS = [
    Setting("ols (sign friction)", "ols"),
    Setting("wls", "wls"),
    Setting("sdp, fixed euclidean 1e-2", "sdp", {"regularization": "euclidean", "weight": 1e-2}),
    Setting("sdp, no prior", "sdp", {"regularization": "none", "weight": 0.0}),
    Setting("sdp auto, min (sign friction)", "sdp"),
    Setting("sdp auto, one_se", "sdp", {"selection": "one_se"}),
    Setting("sdp auto, euclidean", "sdp", {"regularization": "euclidean"}),
    Setting("sdp auto, 3 folds", "sdp", {"folds": 3}),
    Setting("ols, friction auto", "ols", friction="auto"),
    Setting("sdp auto, friction auto (default for logs)", "sdp", friction="auto"),
    Setting("sdp auto, friction auto, interval drift 0", "sdp", friction="auto", friction_drift=0.0),
    Setting("sdp auto, friction auto, interval drift 0.3", "sdp", friction="auto", friction_drift=0.3),
    Setting("sdp auto, friction auto, interval drift 0.7", "sdp", friction="auto", friction_drift=0.7),
]


def real_lwr4() -> list[Split]:
    """The real LWR4+ splits, if ../shared has the runs."""
    found = real_lwr4_runs()
    if found is None:
        return []
    robot, runs = found
    splits = {"2→3": ([2], 3, True), "3→1": ([3], 1, True), "3→2": ([3], 2, True)}
    splits |= {"2+3→1": ([2, 3], 1, False), "2→1": ([2], 1, False)}
    return [
        Split("lwr4+", name, robot, [runs[i] for i in fit], [runs[v]], new)
        for name, (fit, v, new) in splits.items()
    ]


def ours(seed: int) -> list[Split]:
    """lwrlab's simulated LWR4: the shipped optimal motion → a multisine, and → a slower multisine."""
    from hydra.utils import instantiate

    cfg, robot, plant = simulated_lwr4(seed)
    fit = plant.measure(instantiate(cfg.trajectory).sample(robot, cfg.measurement.rate_hz))
    multisine = plant.measure(instantiate(cfg.validation).sample(robot, cfg.measurement.rate_hz))
    slower = instantiate(cfg.validation, harmonics=6, seed=2002).sample(robot, cfg.measurement.rate_hz)
    truth = plant.truth.robot.parameters
    return [
        Split(f"ours (seed {seed})", "→ multisine", robot, [fit], [multisine], True, truth),
        Split(
            f"ours (seed {seed})", "→ slower multisine", robot, [fit], [plant.measure(slower)], True, truth
        ),
    ]


def second_sim(folder: Path) -> list[Split]:
    """The second simulator's splits (every one validates on a motion not fitted)."""
    return [
        Split("second sim", d.name.removeprefix("second sim "), d.robot, d.fit, d.validation, True)
        for d in second_simulator(folder)
    ]


def geared(folder: Path) -> list[Split]:
    """The geared arms' splits (every one validates on a motion not fitted)."""
    from benchmarks.geared_arms import splits

    return [
        Split(data, name, robot, fit, validation, True)
        for data, name, robot, fit, validation in splits(folder)
    ]


def _with_friction(robot: RobotModel, setting: Setting, processed: list[Any]) -> RobotModel:
    """``robot`` with the setting's friction law (``auto``: the one the fit rows choose)."""
    if setting.friction == "sign":
        return robot
    robot = robot.with_friction_law(build("friction", setting.friction))
    chosen, _ = choose_friction(robot, compute_base_parameters(robot), processed)
    return chosen


def evaluate(split: Split, setting: Setting) -> dict[str, float]:
    """Fit ``split`` with ``setting``: validation error (%), coverage, base error (%), fit time."""
    recorded = split.truth is None
    robot = replace(split.robot, friction_terms=("coulomb", "viscous", "offset")) if recorded else split.robot
    processed = [process(m.t, m.q, m.tau, m.dq, **DEFAULTS) for m in split.fit]
    robot = _with_friction(robot, setting, processed)
    base = compute_base_parameters(robot)
    rows = [d.rows(lambda q, dq, ddq: base.base_regressor(regressor(robot, q, dq, ddq))) for d in processed]
    w = np.vstack([r[0] for r in rows])
    tau = np.concatenate([r[1] for r in rows])
    overrides = dict(setting.overrides)
    if setting.estimator == "wls":
        overrides["n_joints"] = robot.n_joints
    estimator = build("estimator", setting.estimator, **overrides)
    started = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        estimator.fit(w, tau, context=IdentificationContext.from_robot(robot, base))
    seconds = time.process_time() - started
    covariance = np.asarray(estimator.covariance_)
    drift = setting.friction_drift
    drifting = drifting_terms(robot.friction_law)
    drifting_values = drift_parameters(base.names, estimator.phi_, drifting) if drift > 0 else None
    friction = None if drifting_values is None else drift * drifting_values  # ρ·φ_f: ρ·τ̂_f

    def predicted(m: Measurement) -> LogPrediction:
        return predict_measurement(robot, base, estimator.phi_, m, DEFAULTS, covariance, friction)

    in_sample = np.mean((tau - w @ estimator.phi_).reshape(-1, robot.n_joints) ** 2, axis=0)
    interval = prediction_interval(estimator, [predicted(m) for m in split.fit], in_sample)
    predictions = [interval.around(predicted(m)) for m in split.validation]
    joints = joint_coverage(predictions)
    row = {
        "validation_%": float(np.mean([100 * p.relative_error for p in predictions])),
        "coverage_%": float(np.mean([100 * p.interval_coverage for p in predictions])),
        "worst_joint_coverage_%": float(100 * np.nanmin(joints)),
        "worst_joint": float(np.nanargmin(joints) + 1),
        **{f"coverage_joint{j}_%": float(100 * c) for j, c in enumerate(joints, start=1)},
        "fit_cpu_s": seconds,
        "prior_weight": float(getattr(estimator, "weight_", np.nan)),
    }
    if split.truth is not None:  # in the chosen law's layout: the true friction's terms, others zero
        truth = split.robot.with_parameters(split.truth)
        true_base = base.base_values(replace(robot, model=truth.model, friction=truth.friction).parameters)
        row["base_error_%"] = float(
            100 * np.linalg.norm(estimator.phi_ - true_base) / np.linalg.norm(true_base)
        )
    return row


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per setting: mean and worst new-motion validation error, score, seen-motion errors, base error."""
    new = table[table.new_motion]
    grouped = new.groupby("setting", sort=False)["validation_%"]
    out = pd.DataFrame({"new-motion mean %": grouped.mean(), "new-motion worst %": grouped.max()})
    out["score %"] = (out["new-motion mean %"] + out["new-motion worst %"]) / 2
    out["coverage %"] = new.groupby("setting", sort=False)["coverage_%"].mean()
    out["worst-joint coverage %"] = new.groupby("setting", sort=False)["worst_joint_coverage_%"].min()
    if "base_error_%" in table and table["base_error_%"].notna().any():
        out["ours base error %"] = table.groupby("setting", sort=False)["base_error_%"].max()
    out["fit CPU s (mean)"] = table.groupby("setting", sort=False)["fit_cpu_s"].mean()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=REPOSITORY / "outputs" / "model_study.csv")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--settings", nargs="*", help="only the settings whose name contains one of these")
    parser.add_argument("--data", nargs="*", help="only the data sets whose name contains one of these")
    args = parser.parse_args()
    settings = [s for s in SETTINGS if not args.settings or any(k in s.name for k in args.settings)]

    def wanted(name: str) -> bool:
        return not args.data or any(k in name for k in args.data)

    with tempfile.TemporaryDirectory() as folder:
        splits = (real_lwr4() if wanted("lwr4+") else []) + [
            s for seed in args.seeds if wanted(f"ours (seed {seed})") for s in ours(seed)
        ]
        splits += second_sim(Path(folder)) if wanted("second sim") else []
        splits += geared(Path(folder)) if wanted("geared") else []
        rows = []
        for split in splits:
            for setting in settings:
                result = evaluate(split, setting)
                rows.append(
                    {
                        "data": split.data,
                        "split": split.name,
                        "new_motion": split.new_motion,
                        "setting": setting.name,
                    }
                    | result
                )
                print(
                    f"{split.data:16s} {split.name:20s} {setting.name:42s} "
                    + "  ".join(f"{k} {v:.4g}" for k, v in result.items()),
                    flush=True,
                )
    table = pd.DataFrame(rows)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.output, index=False)
    table["column"] = table["data"] + " " + table["split"]
    wide = table.pivot(index="setting", columns="column", values="validation_%").reindex(
        [s.name for s in settings]
    )
    print("\nvalidation ‖τ−τ̂‖/‖τ‖ (%)\n")
    print(wide.T.to_markdown(floatfmt=".3g"))
    geared_rows = table["data"].str.startswith("geared")
    for title, part in (("", table[~geared_rows]), (" of the geared arms", table[geared_rows])):
        if len(part):
            print(f"\nsummary over the new-motion splits{title}\n")
            print(summary(part).to_markdown(floatfmt=".3g"))
    print(f"\nwritten {args.output}")


if __name__ == "__main__":
    main()
