"""Rewrite a joint-side log as a geared arm's drives would record it: motor encoder angles and motor torques.

Usage::

    python to_motor_side.py DRIVE IN_LOG OUT_LOG

``DRIVE`` is the robot's ``drive:`` block as one YAML flow mapping (the same text ``run.sh`` passes to
``lwrlab robot.drive=…``), e.g. ``{gear_ratios: [100, 100, 80, 80, 50, 50, 50], coupling: [[7, 6, 0.3]],
position_side: motor, torque_side: motor}``. With ``R = diag(gear_ratios)·C`` the motor angles are
``θ = R·q`` (rad at the motor) and the motor torques ``τ_motor = R⁻ᵀ·τ`` (N·m at the motor shaft):
lwrlab reads such a log back to the joint side (``q = R⁻¹·θ``, ``τ = Rᵀ·τ_motor``) when the robot's
drive block says ``position_side: motor`` and ``torque_side: motor``. ``IN_LOG`` and ``OUT_LOG`` are CSV
or Parquet (by suffix), columns ``t, q1…qN, tau1…tauN`` (optional ``dq1…dqN``: scaled as the angles).

A real geared arm also has rotor inertias and drive friction that this rewriting does not add: the
point here is the reading of motor-side signals, not a new simulation.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from lwrlab.model.drive_train import build_drive_train


def read(path: Path) -> pd.DataFrame:
    return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)


def write(table: pd.DataFrame, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".parquet":
        table.to_parquet(path, index=False)
    else:
        table.to_csv(path, index=False, float_format="%.17g")


def to_motor_side(table: pd.DataFrame, drive_block: dict) -> pd.DataFrame:
    """The log ``table`` (joint side) as the drives of ``drive_block`` measure it."""
    n = sum(1 for column in table.columns if column.startswith("tau"))
    drive = build_drive_train(drive_block, n, "example")
    out = table.copy()
    for prefix, convert in (("q", drive.motor_positions), ("dq", drive.motor_positions)):
        columns = [f"{prefix}{j}" for j in range(1, n + 1)]
        if set(columns) <= set(table.columns):
            out[columns] = convert(table[columns].to_numpy())  # rad (rad/s) at the motors
    taus = [f"tau{j}" for j in range(1, n + 1)]
    out[taus] = drive.motor_torques(table[taus].to_numpy())  # N·m at the motor shafts
    return out


def main() -> None:
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    drive_block = yaml.safe_load(sys.argv[1])
    source, target = Path(sys.argv[2]), Path(sys.argv[3])
    table = read(source)
    motor = to_motor_side(table, drive_block)
    write(motor, target)
    ratio = (
        np.abs(motor.filter(regex=r"^q\d").to_numpy()).max()
        / np.abs(table.filter(regex=r"^q\d").to_numpy()).max()
    )
    print(f"{source.name} → {target} (motor side: angles up to {ratio:.0f}× the joints')")


if __name__ == "__main__":
    main()
