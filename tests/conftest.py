"""Shared fixtures: small, fast versions of the real objects."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import ros_domains
from parsed_configs import parse_each_file_once

import lwrlab.conf  # noqa: F401  (registers the schemas conf/'s YAML files link, for compose from CONF)
from lwrlab.model.robot import RobotModel
from plugins.robots.mdh import load_robot_yaml

REPOSITORY = Path(__file__).resolve().parents[1]
CONF = REPOSITORY / "conf"


def pytest_configure(config: pytest.Config) -> None:
    """The live tests' nodes, and the processes they start, on loopback only and on this process's
    own ROS 2 domain (ros_domains): side by side, test processes never read each other's topics."""
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(ros_domains.ros_domain(0))


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto`` (``make test``): the fast tests on one pytest-xdist worker per CPU this process may
    use (at most one per block of ROS domains); any other selection (``-m slow``) in this one process,
    as its end-to-end runs each load the machine and the live ones hold real-time guards."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return int(os.environ["PYTEST_XDIST_AUTO_NUM_WORKERS"])  # xdist's own setting, as it reads it
    cpus = len(os.sched_getaffinity(0))
    if config.option.markexpr != "not slow" or cpus < 2:
        return 0
    return min(cpus, ros_domains.blocks())


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
