"""Shared fixtures: small, fast versions of the real objects."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from parsed_configs import parse_each_file_once

import lwrlab.conf  # noqa: F401  (registers the schemas conf/'s YAML files link, for compose from CONF)
from lwrlab.model.robot import RobotModel
from plugins.robots.mdh import load_robot_yaml

REPOSITORY = Path(__file__).resolve().parents[1]
CONF = REPOSITORY / "conf"


@pytest.fixture(scope="session", autouse=True)
def _config_files_parsed_once() -> Iterator[None]:
    """The suite composes the same conf/ files hundreds of times: each is parsed once (parsed_configs)."""
    with parse_each_file_once():
        yield


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def lwr4() -> RobotModel:
    """The KUKA LWR4 CAD model of conf/robot/kuka_lwr4.yaml."""
    return load_robot_yaml(CONF / "robot" / "kuka_lwr4.yaml")


@pytest.fixture(scope="session")
def panda() -> RobotModel:
    """The Franka Emika Panda of conf/robot/panda.yaml."""
    return load_robot_yaml(CONF / "robot" / "panda.yaml")


STRAY_STORE = REPOSITORY / "mlflow.db"
"""MLflow's default store in the working folder: what a look-up without a tracking URI creates. The
repository's store is ``outputs/mlflow.db``; the root stays clean."""
_STRAY_STORE_BEFORE = STRAY_STORE.exists()


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Fail a run that left MLflow's default store at the repository root."""
    if STRAY_STORE.exists() and not _STRAY_STORE_BEFORE:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
        print(
            f"\n{STRAY_STORE}: a test made MLflow's default store at the repository root (no tracking URI?)"
        )
