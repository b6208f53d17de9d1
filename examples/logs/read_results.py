"""Read an identification run's results with pandas: torque errors per log and joint, the friction law chosen.

Usage::

    python read_results.py RUN_FOLDER

``RUN_FOLDER`` is the folder of one ``lwrlab task=identification plant=log …`` run (``hydra.run.dir``).
It reads

* ``predicted_torque.parquet``: one row per scored sample of every log (``log``, ``role``
  identification | validation, ``t`` s, measured ``tau1…N`` and predicted ``tau_hat1…N`` N·m, the 95 %
  prediction interval ``tau_lo1…N``, ``tau_hi1…N``), from which it recomputes the relative error
  ‖τ − τ̂‖/‖τ‖ of each log (the run's ``validation_rel_error_<log>``), the RMS error per joint and the
  interval's coverage;
* ``friction_choice.csv`` (written with ``friction=auto``, the default for logs): every candidate law,
  with and without rotor inertias, and its held-out NRMS (%); the ``chosen`` one is the simplest within
  one standard error of the best, on the mean or on the mean and the worst held-out block together.

and prints them as tables. It also writes ``errors_per_log.csv`` into the run folder.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd


def errors_per_log(predicted: pd.DataFrame) -> pd.DataFrame:
    """Per log: role, samples, ‖τ − τ̂‖/‖τ‖ (%), RMS error per joint (N·m) and interval coverage (%)."""
    joints = sorted(int(c[3:]) for c in predicted.columns if c.startswith("tau") and c[3:].isdigit())
    tau = [f"tau{j}" for j in joints]
    tau_hat = [f"tau_hat{j}" for j in joints]
    rows = []
    for (log, role), samples in predicted.groupby(["log", "role"], sort=False):
        measured = samples[tau].to_numpy()
        residual = measured - samples[tau_hat].to_numpy()
        inside = (samples[[f"tau_lo{j}" for j in joints]].to_numpy() <= measured) & (
            measured <= samples[[f"tau_hi{j}" for j in joints]].to_numpy()
        )
        rows.append(
            {
                "log": log,
                "role": role,
                "samples": len(samples),
                "rel_error_%": 100 * np.linalg.norm(residual) / np.linalg.norm(measured),
                **{f"rms{j} [N·m]": np.sqrt(np.mean(residual[:, k] ** 2)) for k, j in enumerate(joints)},
                "interval_coverage_%": 100 * inside.mean(),
            }
        )
    return pd.DataFrame(rows)


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    run = Path(sys.argv[1])
    predicted = pd.read_parquet(run / "predicted_torque.parquet")
    errors = errors_per_log(predicted)
    errors.to_csv(run / "errors_per_log.csv", index=False)
    print(f"\n{run.name}: torque errors per log (from predicted_torque.parquet)\n")
    print(errors.to_markdown(index=False, floatfmt=".4g"))

    choice_file = run / "friction_choice.csv"
    if choice_file.is_file():
        choice = pd.read_csv(choice_file).sort_values("cv_nrms_percent", ignore_index=True)
        rank = int(choice.index[choice["chosen"]][0])
        chosen = choice.iloc[rank]
        # the candidates that scored as well or better, down to the chosen one (simpler than they are)
        shown = pd.concat([choice.iloc[: min(rank, 7)], choice.iloc[[rank]]])
        print(
            f"\nfriction law chosen among {len(choice)} candidates: {chosen['candidate']} "
            f"(held-out NRMS {chosen['cv_nrms_percent']:.3f} %, rank {rank + 1}); the best down to it:\n"
        )
        print(shown.to_markdown(index=False, floatfmt=".4g"))


if __name__ == "__main__":
    main()
