"""A motion's CSV, formatted a row at a time, is the text pandas writes for it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from lwrlab.io.artifacts import CSV_FLOAT_FORMAT, save_trajectory_csv, trajectory_frame
from lwrlab.trajectory.core import Trajectory

VALUES = st.floats(allow_nan=False, width=64) | st.sampled_from([0.0, -0.0, 1e-300, -1e300, 0.1, 1 / 3])


def _trajectory(values: np.ndarray) -> Trajectory:
    joints = (values.shape[1] - 1) // 3
    return Trajectory(
        values[:, 0],
        values[:, 1 : 1 + joints],
        values[:, 1 + joints : 1 + 2 * joints],
        values[:, 1 + 2 * joints :],
    )


@settings(max_examples=60, deadline=None)
@given(values=arrays(np.float64, st.tuples(st.integers(1, 6), st.sampled_from([4, 7, 22])), elements=VALUES))
def test_the_csv_is_what_pandas_writes(tmp_path_factory: pytest.TempPathFactory, values: np.ndarray) -> None:
    trajectory = _trajectory(values)
    path = save_trajectory_csv(trajectory, tmp_path_factory.mktemp("csv") / "motion.csv")
    expected = trajectory_frame(trajectory).to_csv(index=False, float_format=CSV_FLOAT_FORMAT)
    assert path.read_bytes() == expected.encode()


def test_a_missing_value_is_an_empty_field_as_pandas_writes_it(tmp_path: Path) -> None:
    values = np.arange(8.0).reshape(2, 4)
    values[1, 2] = np.nan
    path = save_trajectory_csv(_trajectory(values), tmp_path / "motion.csv")
    assert path.read_text().splitlines() == ["t,q1,dq1,ddq1", "0,1,2,3", "4,5,,7"]
    read = pd.read_csv(path)
    assert np.isnan(read["dq1"][1]) and read["ddq1"][1] == 7.0
