"""lwrlab outside its source tree: configs, the tool library and the shipped motion come from the package.

The fast tests check, in the source tree, that everything is found through the package (``lwrlab.conf``,
``pkg://`` data paths) whatever the working directory. The slow test builds a wheel offline, installs it
in a fresh virtual environment outside the repository (its dependencies borrowed from the running one)
and runs ``lwrlab task=identification`` and the tool library in an empty folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from lwrlab.pipeline.tools.library import tool_names
from lwrlab.resources import CONFIG_SEARCH_PATH, config_group, resolve_data_path

REPOSITORY = Path(__file__).resolve().parents[1]
CONF = REPOSITORY / "conf"
SHIPPED_MOTION = REPOSITORY / "lwrlab" / "data" / "exciting_motions" / "kuka_lwr4_logdet_10s.yaml"
PACKAGE_SOURCES = ("pyproject.toml", "README.md", "conf", "lwrlab", "plugins")
"""What a wheel is built from (copied out, so the build leaves nothing in the source tree)."""

SHORT_IDENTIFICATION = (
    "task=identification",
    "tracking=none",
    "validation.duration=4",
    "plant.show_progress=false",
)
"""The identification on the shipped 10 s motion (read from the package), validated on a 4 s motion."""


def _conf_yaml_files() -> set[str]:
    return {path.relative_to(CONF).as_posix() for path in CONF.rglob("*.yaml")}


def test_config_tree_and_tool_library_are_found_through_the_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import lwrlab.conf

    monkeypatch.chdir(tmp_path)  # nothing may depend on the working directory
    assert CONFIG_SEARCH_PATH == "pkg://lwrlab.conf"
    assert (
        Path(lwrlab.conf.__file__).resolve().parent == CONF.resolve()
    )  # in the source tree: the link to conf/
    shipped_tools = {path.stem for path in (CONF / "tool").glob("*.yaml")}
    assert set(config_group("tool")) == shipped_tools and len(shipped_tools) >= 10
    assert tool_names() == sorted(shipped_tools)
    with pytest.raises(FileNotFoundError, match="no config group 'no_such_group'"):
        config_group("no_such_group")


def test_the_default_motion_is_a_package_file_and_user_paths_stay_paths(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    reference = OmegaConf.load(CONF / "trajectory" / "optimal.yaml").from_file
    assert reference.startswith("pkg://")
    assert resolve_data_path(reference).resolve() == SHIPPED_MOTION.parent.resolve()  # the library
    assert resolve_data_path("motions/mine.yaml") == Path(
        "motions/mine.yaml"
    )  # the user's, relative to the cwd
    assert resolve_data_path("~/mine.yaml") == Path.home() / "mine.yaml"
    with pytest.raises(FileNotFoundError, match="no file 'data/none.yaml' in package 'lwrlab'"):
        resolve_data_path("pkg://lwrlab/data/none.yaml")
    with pytest.raises(FileNotFoundError, match="no package 'no_such_package'"):
        resolve_data_path("pkg://no_such_package/motion.yaml")


def _check(command: list[str], cwd: Path, environment: dict[str, str]) -> str:
    finished = subprocess.run(command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=300)
    assert finished.returncode == 0, (
        f"{command} exited {finished.returncode}:\n{finished.stdout[-3000:]}\n{finished.stderr[-3000:]}"
    )
    return finished.stdout + finished.stderr


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path | dict[str, str]]:
    """A wheel of the working tree installed in a fresh virtual environment outside the repository.

    The environment has no pip and no copy of the dependencies: a ``.pth`` file puts the running
    environment's site-packages behind its own (with that folder's ``.pth`` files, less the editable
    install of lwrlab), so only lwrlab and plugins come from the wheel.
    """
    root = tmp_path_factory.mktemp("wheel")
    source, wheelhouse, environment_dir = root / "source", root / "wheelhouse", root / "env"
    source.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    for name in PACKAGE_SOURCES:
        origin = REPOSITORY / name
        if origin.is_dir():
            shutil.copytree(origin, source / name, symlinks=True, ignore=ignore)  # lwrlab/conf stays a link
        else:
            shutil.copy2(origin, source / name)
    environment = {
        key: value for key, value in os.environ.items() if key not in {"PYTHONPATH", "MLFLOW_TRACKING_URI"}
    }
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input"]
    _check(
        [
            *pip,
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-w",
            str(wheelhouse),
            str(source),
        ],
        root,
        environment,
    )
    (wheel,) = wheelhouse.glob("lwrlab-*.whl")
    _check([sys.executable, "-m", "venv", "--without-pip", str(environment_dir)], root, environment)
    python = environment_dir / "bin" / "python"
    site_packages = Path(
        _check(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            root,
            environment,
        ).strip()
    )
    dependencies = Path(sysconfig.get_paths()["purelib"])
    # "00_" sorts first, so the .pth files copied below find the modules they import.
    (site_packages / "00_lwrlab_dependencies.pth").write_text(f"{dependencies}\n")
    for path_file in dependencies.glob("*.pth"):
        if not path_file.name.startswith("__editable__.lwrlab"):
            shutil.copy2(path_file, site_packages / path_file.name)
    _check(
        [*pip, "--python", str(python), "install", "--quiet", "--no-deps", "--no-index", str(wheel)],
        root,
        environment,
    )
    return {"wheel": wheel, "env": environment_dir, "python": python, "environment": environment}


@pytest.mark.slow
def test_wheel_ships_the_config_tree_and_the_shipped_motion(installed: dict) -> None:
    with zipfile.ZipFile(installed["wheel"]) as wheel:
        names = set(wheel.namelist())
    shipped = {
        name.removeprefix("lwrlab/conf/")
        for name in names
        if name.startswith("lwrlab/conf/") and name.endswith(".yaml")
    }
    assert shipped == _conf_yaml_files()
    assert {
        "lwrlab/conf/__init__.py",
        "lwrlab/data/exciting_motions/kuka_lwr4_logdet_10s.yaml",
        "plugins/trajectories/optimal.py",
    } <= names


@pytest.mark.slow
def test_installed_wheel_runs_the_identification_and_loads_the_tool_library_in_an_empty_folder(
    installed: dict, tmp_path: Path
) -> None:
    env_dir, environment = installed["env"], installed["environment"]
    probe = (
        "import json, lwrlab, lwrlab.conf, plugins; from lwrlab.pipeline.tools.library import load_library; library = load_library(); "
        "print(json.dumps({'modules': [lwrlab.__file__, lwrlab.conf.__file__, plugins.__file__], "
        "'tools': list(library.names), 'large_roller_mass': library['large_roller'].mass}))"
    )
    found = json.loads(
        _check([str(installed["python"]), "-c", probe], tmp_path, environment).strip().splitlines()[-1]
    )
    for module in found["modules"]:  # the installed copy, not the source tree
        assert Path(module).resolve().is_relative_to(env_dir.resolve()), module
    assert sorted(found["tools"]) == sorted(path.stem for path in (CONF / "tool").glob("*.yaml"))
    assert found["large_roller_mass"] == pytest.approx(0.2)

    workdir = tmp_path / "empty"
    workdir.mkdir()
    output = _check([str(env_dir / "bin" / "lwrlab"), *SHORT_IDENTIFICATION], workdir, environment)
    # the default motion was read from the installed package, not from the repository
    loaded = [line for line in output.splitlines() if "exciting motion loaded from" in line]
    assert loaded and str(env_dir) in loaded[0] and str(REPOSITORY) not in output
    (run_dir,) = workdir.glob("outputs/runs/*/*")
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["rms_mean"] < 0.5  # N·m: identified well (the sensor noise is 0.1 N·m)
    assert (run_dir / "summary.md").is_file() and (run_dir / "base_parameters.csv").is_file()
    hydra_config = OmegaConf.load(run_dir / ".hydra" / "hydra.yaml")
    assert {"provider": "main", "schema": "pkg", "path": "lwrlab.conf"} in OmegaConf.to_container(
        hydra_config.hydra.runtime.config_sources
    )
