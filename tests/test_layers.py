"""The layer contract of ARCHITECTURE.md (Layers), read from the source: every import arrow points down.

::

    cli ──► pipeline ──► core (lwrlab/…), figures, plugins, tracking
    tracking ──► core, figures          (an edge: no pipeline, no cli, no plugin)
    figures ──► core                    (the only users of matplotlib; no pipeline, tracking, hydra, mlflow)
    plugins ──► core                    (no hydra, omegaconf, mlflow; no other plugin)
    core: numpy, scipy, pinocchio, pandas (no hydra, omegaconf, mlflow, matplotlib; no pipeline,
          tracking, cli, figures, plugins: it receives plugins built from config)

Every ``import`` counts, at module level or inside a function (the whole syntax tree is walked),
except under ``if TYPE_CHECKING:`` (annotations only, never executed). Relative imports are resolved
to absolute names. ``lwrlab/conf`` holds the shipped configs (data) and is not a layer.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[1]
PACKAGES = ("lwrlab", "plugins")

FRAMEWORKS = ("hydra", "omegaconf", "mlflow")
"""The config and tracking frameworks: only the pipeline, tracking and the CLI may use them."""


ABOVE_CORE = ("lwrlab.pipeline", "lwrlab.tracking", "lwrlab.cli")
"""The edges and the top: the config and tracking frameworks' users."""


@dataclass(frozen=True)
class Rule:
    """Modules of one layer and the imports they must not make."""

    layer: str
    forbidden: tuple[str, ...]
    """Module names (and everything below them) the layer must not import."""
    why: str


RULES: dict[str, Rule] = {
    rule.layer: rule
    for rule in (
        Rule(
            "core",
            (*FRAMEWORKS, "matplotlib", *ABOVE_CORE, "lwrlab.figures", "plugins"),
            "the core computes: no config or tracking framework, no stage above it, no plugin, no drawing",
        ),
        Rule(
            "figures",
            (*FRAMEWORKS, *ABOVE_CORE, "plugins"),
            "figures draw value objects and tables, below the pipeline and tracking",
        ),
        Rule(
            "plugins",
            (*FRAMEWORKS, "matplotlib", *ABOVE_CORE, "lwrlab.figures", "plugins"),
            "a plugin depends on the core only: never on hydra or mlflow, never on another plugin",
        ),
        Rule(
            "tracking",
            ("matplotlib", "lwrlab.pipeline", "lwrlab.cli", "plugins"),
            "tracking is an edge: the pipeline calls it, never the reverse; it draws through lwrlab.figures",
        ),
        Rule(
            "pipeline",
            ("matplotlib", "lwrlab.cli"),
            "the CLI calls the pipeline, never the reverse; it draws through lwrlab.figures",
        ),
        Rule("cli", (), "the top: may import anything"),
    )
}
"""Per layer, what it must not import. ``matplotlib`` outside ``lwrlab/figures`` means figure code elsewhere."""


def layer_of(module: str) -> str | None:
    """The layer of a dotted module name (``None`` for the shipped config package)."""
    parts = module.split(".")
    if parts[0] == "plugins":
        return "plugins"
    if module == "lwrlab.cli":
        return "cli"
    if len(parts) > 1 and parts[1] in ("pipeline", "tracking", "figures"):
        return parts[1]
    if len(parts) > 1 and parts[1] == "conf":
        return None
    return "core"


def module_name(path: Path, root: Path = REPOSITORY) -> str:
    """``lwrlab/model/robot.py`` → ``lwrlab.model.robot``; a package's ``__init__.py`` → the package."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking_block(node: ast.AST) -> bool:
    test = node.test if isinstance(node, ast.If) else None
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _walk_executed(node: ast.AST) -> Iterator[ast.AST]:
    """Every node below ``node`` but the bodies of ``if TYPE_CHECKING:`` (their ``else`` still runs)."""
    for child in ast.iter_child_nodes(node):
        if _is_type_checking_block(child):
            assert isinstance(child, ast.If)
            for statement in child.orelse:
                yield statement
                yield from _walk_executed(statement)
            continue
        yield child
        yield from _walk_executed(child)


def imports(source: str, module: str, is_package: bool = False) -> Iterator[tuple[int, str]]:
    """(line, absolute imported name) of every executed import of a module's source.

    ``from a import b`` yields ``a.b`` (``b`` may be a submodule); relative imports are resolved
    against ``module``.
    """
    for node in _walk_executed(ast.parse(source)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                package = module.split(".") if is_package else module.split(".")[:-1]
                package = package[: len(package) - (node.level - 1)]
                base = ".".join([*package, *([node.module] if node.module else [])])
            for alias in node.names:
                yield node.lineno, f"{base}.{alias.name}" if alias.name != "*" else base


def _below(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def violations(source: str, module: str, path: str, is_package: bool = False) -> list[str]:
    """Messages for every import of ``module`` its layer forbids (module, file:line, the import)."""
    layer = layer_of(module)
    if layer is None:
        return []
    rule = RULES[layer]
    found = []
    for line, name in imports(source, module, is_package):
        for prefix in rule.forbidden:
            if _below(name, prefix) and not _below(name, module):
                found.append(
                    f"{path}:{line}: {layer} module {module} imports {name} (forbidden: {prefix}; {rule.why})"
                )
                break
    return found


def source_modules() -> list[tuple[Path, str]]:
    """Every Python module of the two packages, with its dotted name."""
    files = sorted(path for package in PACKAGES for path in (REPOSITORY / package).rglob("*.py"))
    return [(path, module_name(path)) for path in files]


def relative(path: Path) -> str:
    return str(path.relative_to(REPOSITORY))


MODULES = source_modules()


def test_every_module_is_read() -> None:
    layers = {layer_of(module) for _, module in MODULES}
    assert {"core", "plugins", "pipeline", "tracking", "figures", "cli"} <= layers
    assert len(MODULES) > 50


@pytest.mark.parametrize("layer", [name for name in RULES if RULES[name].forbidden])
def test_imports_point_down(layer: str) -> None:
    found = [
        message
        for path, module in MODULES
        if layer_of(module) == layer
        for message in violations(
            path.read_text(), module, relative(path), is_package=path.name == "__init__.py"
        )
    ]
    assert not found, f"{len(found)} import(s) against the layer contract:\n" + "\n".join(found)


# --- the checker itself: it sees what it must and only that ---------------------------------------

FORBIDDEN_IMPORTS = [  # (module, its source, the forbidden import the checker must name)
    # the arrows the layer contract was written against
    (
        "lwrlab.reference.table2",
        "def main():\n    from plugins.robots.mdh import load_robot_yaml\n",
        "plugins.robots",
    ),
    (
        "plugins.robots.urdf",
        "from plugins.robots.mdh import build_friction\n",
        "plugins.robots.mdh.build_friction",
    ),
    ("plugins.robots.identified", "import hydra.utils\n", "hydra.utils"),
    ("plugins.robots.identified", "def f():\n    import mlflow.artifacts\n", "mlflow.artifacts"),
    (
        "lwrlab.tracking.benchmark_summary",
        "from lwrlab.pipeline.estimator_benchmark import write_summary\n",
        "lwrlab.pipeline.estimator_benchmark.write_summary",
    ),
    ("lwrlab.tracking.benchmark_summary", "from lwrlab import pipeline\n", "lwrlab.pipeline"),
    ("lwrlab.tracking.benchmark_summary", "from ..pipeline import estimator_benchmark\n", "lwrlab.pipeline"),
    ("lwrlab.tracking.compare", "def draw():\n    import matplotlib.pyplot as plt\n", "matplotlib.pyplot"),
    # the other arrows of the contract
    ("lwrlab.figures.residuals", "import mlflow\n", "mlflow"),
    ("lwrlab.figures.residuals", "from lwrlab.tracking.store import open_store\n", "lwrlab.tracking.store"),
    ("lwrlab.model.robot", "import omegaconf\n", "omegaconf"),
    ("lwrlab.pipeline.painting", "from lwrlab.cli import main\n", "lwrlab.cli.main"),
    ("lwrlab.pipeline.estimator_benchmark", "import matplotlib\n", "matplotlib"),
    ("plugins.criteria.cond", "from lwrlab.pipeline.identification import identify\n", "lwrlab.pipeline"),
    ("lwrlab.model", "from .. import tracking\n", "lwrlab.tracking"),
]

ALLOWED_IMPORTS = [
    ("lwrlab.model.robot", "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import hydra\n"),
    (
        "lwrlab.model.robot",
        "import typing\nif typing.TYPE_CHECKING:\n    from plugins.robots.mdh import build_robot\n",
    ),
    ("lwrlab.model.robot", "from lwrlab.model.inertia import to_pin_inertia\nimport hydrant\n"),
    ("lwrlab.tracking.compare", "import mlflow\nfrom lwrlab.figures.torques import rms_per_joint_by_group\n"),
    (
        "lwrlab.pipeline.tools",
        "from hydra.utils import instantiate\nfrom plugins.classifiers.nearest import Nearest\n",
    ),
    ("lwrlab.cli", "from lwrlab.pipeline.chain import run_chain\n"),
    (
        "lwrlab.figures.torques",
        "import matplotlib.pyplot as plt\nfrom lwrlab.model.robot import RobotModel\n",
    ),
    ("lwrlab.conf", "import hydra\n"),
]


@pytest.mark.parametrize(("module", "source", "forbidden"), FORBIDDEN_IMPORTS)
def test_the_checker_finds_a_forbidden_import(module: str, source: str, forbidden: str) -> None:
    found = violations("import numpy as np\n" + source, module, "x.py", is_package=module == "lwrlab.model")
    line = 2 + next(
        i for i, text in enumerate(source.splitlines()) if "import" in text
    )  # after the numpy line
    assert len(found) == 1, found
    assert found[0].startswith(f"x.py:{line}: ") and f" {module} imports {forbidden}" in found[0], found


@pytest.mark.parametrize(("module", "source"), ALLOWED_IMPORTS)
def test_the_checker_allows_what_the_layers_allow(module: str, source: str) -> None:
    assert violations(source, module, "x.py") == []


def test_code_under_type_checking_else_still_counts() -> None:
    source = "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    pass\nelse:\n    import mlflow\n"
    assert len(violations(source, "lwrlab.model.robot", "x.py")) == 1
