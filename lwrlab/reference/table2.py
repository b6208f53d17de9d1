"""The LWR4 CAD model against the CAD column of the paper's Table II.

``python -m lwrlab.reference.table2`` prints, for every base parameter of Table II, the value of
``conf/robot/kuka_lwr4.yaml``, the paper's CAD value and their relative difference.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.model.description import load_robot_yaml
from lwrlab.model.robot import RobotModel
from lwrlab.reference import paper_results
from lwrlab.resources import config_group

CAD_COLUMN = 0
"""Position of the CAD value in each row of ``table2_base_parameters``."""


def table2_cad_comparison(robot: RobotModel) -> pd.DataFrame:
    """Base parameters of ``robot`` next to the paper's CAD values (rows: Table II's inertial parameters).

    Columns: ``model``, ``paper_cad``, ``relative_difference`` (NaN where the paper's value is 0).
    A ``KeyError`` names any parameter of Table II missing from the robot's base set.
    """
    base = compute_base_parameters(robot)
    values = base.base_values(robot.parameters)
    rows = {
        name: row[CAD_COLUMN]
        for name, row in paper_results()["table2_base_parameters"].items()
        if name != "columns" and row[CAD_COLUMN] is not None
    }
    model = np.array([values[base.index(name)] for name in rows])
    paper = np.array(list(rows.values()), dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(paper != 0.0, (model - paper) / np.abs(paper), np.nan)
    return pd.DataFrame(
        {"model": model, "paper_cad": paper, "relative_difference": relative},
        index=pd.Index(list(rows), name="parameter"),
    )


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    path = (
        Path(argv[0]) if argv else config_group("robot")["kuka_lwr4"]
    )  # the shipped config, also from a wheel
    table = table2_cad_comparison(load_robot_yaml(path))
    print(f"Base parameters of {path} vs the CAD column of Table II (Katsumata et al. 2019)\n")
    print(table.to_markdown(floatfmt=".4g"))
    print(f"\nlargest |relative difference|: {np.nanmax(np.abs(table['relative_difference'])):.2%}")


if __name__ == "__main__":
    main()
