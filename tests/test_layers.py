"""The layer contract of ARCHITECTURE.md (Layers), read from the source: every import arrow points down.

::

    cli ──► pipeline ──► core (lwrlab/…), figures, plugins, tracking
    tracking ──► core, figures          (an edge: no pipeline, no cli, no plugin)
    figures ──► core                    (the only users of matplotlib; no pipeline, tracking, hydra, mlflow)
    plugins ──► core                    (no hydra, omegaconf, mlflow; no other plugin)
    core: numpy, scipy, pinocchio, pandas (no hydra, omegaconf, mlflow, matplotlib; no pipeline,
          tracking, cli, figures, plugins: it receives plugins built from config)

Inside a package the arrows point down too: no import cycle among a package's modules and
sub-packages (every package of ``lwrlab`` and ``plugins``), and the parts of ``lwrlab.tracking``
and of ``lwrlab.pipeline`` import only the parts below them::

    companion ──► lifecycle ──► models ──► runs ──► store ──► job_config
    reports ──────────────────────────────► runs, store, job_config

    chain ──► studies, painting, monitor ──► tools ──► identification ──► config_nodes, config_checks, build
              live ──► monitor
              studies, painting ──────────► excitation ─────────────────► config_nodes, config_checks, build

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
"""Per layer, what it must not import.

``matplotlib`` outside ``lwrlab/figures`` means figure code elsewhere.
"""


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
        "lwrlab.tracking.reports.benchmark_summary",
        "from lwrlab.pipeline.studies.estimator_benchmark import write_summary\n",
        "lwrlab.pipeline.studies.estimator_benchmark.write_summary",
    ),
    ("lwrlab.tracking.reports.benchmark_summary", "from lwrlab import pipeline\n", "lwrlab.pipeline"),
    (
        "lwrlab.tracking.reports.benchmark_summary",
        "from ...pipeline import estimator_benchmark\n",
        "lwrlab.pipeline",
    ),
    (
        "lwrlab.tracking.reports.compare",
        "def draw():\n    import matplotlib.pyplot as plt\n",
        "matplotlib.pyplot",
    ),
    # the other arrows of the contract
    ("lwrlab.figures.residuals", "import mlflow\n", "mlflow"),
    (
        "lwrlab.figures.residuals",
        "from lwrlab.tracking.store.sqlite import open_store\n",
        "lwrlab.tracking.store.sqlite",
    ),
    ("lwrlab.model.robot", "import omegaconf\n", "omegaconf"),
    ("lwrlab.pipeline.painting", "from lwrlab.cli import main\n", "lwrlab.cli.main"),
    ("lwrlab.pipeline.studies.estimator_benchmark", "import matplotlib\n", "matplotlib"),
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
    (
        "lwrlab.tracking.reports.compare",
        "import mlflow\nfrom lwrlab.figures.torques import rms_per_joint_by_group\n",
    ),
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


# --- inside a package: one-way arrows between its modules and sub-packages ---------------------
#
# A package's children are its modules and its sub-packages (a sub-package's modules count as the
# sub-package; its ``__init__`` as ``__init__``). An import between two children is an arrow; the
# arrows of every package must form no cycle, so that each child can be read, tested and moved
# knowing only what lies below it.

Graph = dict[str, set[str]]


def _child(module: str, package: str) -> str | None:
    """The child of ``package`` that ``module`` lies in (``__init__`` for the package itself)."""
    if module == package:
        return "__init__"
    if not module.startswith(package + "."):
        return None
    return module[len(package) + 1 :].split(".")[0]


def package_graph(package: str, sources: dict[str, tuple[str, bool]]) -> Graph:
    """The arrows between ``package``'s children, from ``{module: (source, is_package)}``.

    An imported name (``a.b.C``) counts as the longest known module it starts with.
    """
    known = set(sources)
    graph: Graph = {}
    for module, (source, is_package) in sources.items():
        child = _child(module, package)
        if child is None:
            continue
        graph.setdefault(child, set())
        for _, name in imports(source, module, is_package):
            parts = name.split(".")
            while parts and ".".join(parts) not in known:
                parts.pop()
            target = _child(".".join(parts), package) if parts else None
            if target is not None and target != child:
                graph[child].add(target)
    return graph


def cycles(graph: Graph) -> list[frozenset[str]]:
    """The strongly connected components of more than one node (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[frozenset[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in sorted(graph.get(node, ())):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(frozenset(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _cycle_text(graph: Graph, cycle: frozenset[str]) -> str:
    arrows = [f"{a} → {b}" for a in sorted(cycle) for b in sorted(graph[a] & cycle)]
    return f"{{{', '.join(sorted(cycle))}}}: " + "; ".join(arrows)


SOURCES = {
    module: (path.read_text(), path.name == "__init__.py")
    for path, module in MODULES
    if layer_of(module) is not None
}
PACKAGE_NAMES = sorted({module for path, module in MODULES if path.name == "__init__.py"} & set(SOURCES))


def test_every_package_is_checked() -> None:
    assert {"lwrlab", "lwrlab.io", "lwrlab.tracking", "lwrlab.tracking.runs", "plugins"} <= set(PACKAGE_NAMES)


@pytest.mark.parametrize("package", PACKAGE_NAMES)
def test_no_import_cycle_inside_a_package(package: str) -> None:
    graph = package_graph(package, SOURCES)
    found = cycles(graph)
    assert not found, f"import cycle(s) among the children of {package} (make one arrow point down):\n" + (
        "\n".join(_cycle_text(graph, cycle) for cycle in found)
    )


# --- lwrlab.tracking's sub-packages and the arrows between them ----------------------------------


@dataclass(frozen=True)
class SubPackage:
    """A part of a package and the other parts it may import."""

    name: str
    may_import: tuple[str, ...]
    why: str


TRACKING = "lwrlab.tracking"
TRACKING_PARTS: dict[str, SubPackage] = {
    part.name: part
    for part in (
        SubPackage(
            "job_config",
            (),
            "what is read from a job's config (params, names, provenance tags, secrets) is pure: "
            "the bottom, testable without a store",
        ),
        SubPackage(
            "store",
            ("job_config",),
            "which store a job logs to and its safe use by many processes: below every run, "
            "ignorant of how runs are started, ended or read back",
        ),
        SubPackage(
            "runs",
            ("job_config", "store"),
            "runs in the store (logged, searched, ended, synced later) serve both the callback's "
            "lifecycle and the reports, so they import neither",
        ),
        SubPackage(
            "models",
            ("job_config", "store", "runs"),
            "identified models as MLflow Models (logged, registered, resolved from a URI) are what a "
            "job's run is given at its end and what a task reads: below the lifecycle, above the runs",
        ),
        SubPackage(
            "lifecycle",
            ("job_config", "store", "runs", "models"),
            "the hooks of a job and a sweep sequence the runs; the callback the configs name and its "
            "companion sit above them and hand in what they need (no arrow back up)",
        ),
        SubPackage(
            "companion",
            ("job_config", "store", "runs", "models", "lifecycle"),
            "the top of the logging side: the configured callback chooses between the in-process "
            "lifecycle and the companion process; nothing below knows it exists",
        ),
        SubPackage(
            "reports",
            ("job_config", "store", "runs"),
            "reading runs back (compare, report, benchmark summary) never starts, ends or logs a "
            "job's run: it needs neither the lifecycle nor the companion",
        ),
    )
}
"""The arrows between the parts of :mod:`lwrlab.tracking`; the package's ``__init__`` may name any."""


def part_violations(package: str, parts: dict[str, SubPackage], graph: Graph) -> list[str]:
    """Messages for every arrow between ``package``'s parts that ``parts`` does not allow."""
    found = []
    for part, targets in sorted(graph.items()):
        if part == "__init__":
            continue
        rule = parts.get(part)
        if rule is None:
            found.append(f"{package}.{part}: a part with no rule (declare its arrows)")
            continue
        for target in sorted(targets - set(rule.may_import)):
            found.append(f"{package}.{part} imports {package}.{target} ({rule.why})")
    return found


def tracking_part_violations(graph: Graph) -> list[str]:
    """Messages for every arrow between tracking's parts that :data:`TRACKING_PARTS` does not allow."""
    return part_violations(TRACKING, TRACKING_PARTS, graph)


def test_tracking_is_made_of_sub_packages_that_say_what_they_own() -> None:
    folder = REPOSITORY / "lwrlab" / "tracking"
    assert not [path.name for path in folder.glob("*.py") if path.name != "__init__.py"], (
        "tracking's modules live in its parts (sub-packages)"
    )
    parts = {path.parent.name for path in folder.glob("*/__init__.py")}
    assert parts == set(TRACKING_PARTS), "every part of tracking has a rule, every rule a part"
    for part in parts:
        docstring = ast.get_docstring(ast.parse((folder / part / "__init__.py").read_text()))
        assert docstring and len(docstring) > 80, f"{TRACKING}.{part}/__init__.py: say what the part owns"


def test_tracking_parts_import_only_the_parts_below() -> None:
    found = tracking_part_violations(package_graph(TRACKING, SOURCES))
    assert not found, "\n".join(found)


# --- the cycle and arrow checkers themselves ------------------------------------------------------


def _fake(sources: dict[str, str]) -> dict[str, tuple[str, bool]]:
    return {
        module: (source, module.endswith("pkg") or module.count(".") == 0)
        for module, source in sources.items()
    }


def test_the_checker_finds_a_cycle_through_a_function_level_import() -> None:
    sources = _fake(
        {
            "pkg": "",
            "pkg.a": "from pkg.b import B\n",
            "pkg.b": "from pkg.c import helper\n",
            "pkg.c": "def helper():\n    from pkg.a import A\n",
            "pkg.d": "from pkg.a import A\n",
        }
    )
    graph = package_graph("pkg", sources)
    assert cycles(graph) == [frozenset({"a", "b", "c"})]
    del sources["pkg.c"]
    assert cycles(package_graph("pkg", sources)) == []


def test_the_checker_finds_a_cycle_between_sub_packages_but_not_under_type_checking() -> None:
    sources = _fake(
        {
            "pkg": "",
            "pkg.low": "",
            "pkg.low.x": "from ..high.y import Y\n",
            "pkg.high": "",
            "pkg.high.y": "from pkg.low import x\n",
        }
    )
    assert cycles(package_graph("pkg", sources)) == [frozenset({"low", "high"})]
    sources["pkg.low.x"] = (
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.high.y import Y\n",
        False,
    )
    assert cycles(package_graph("pkg", sources)) == []


def test_the_checker_finds_an_arrow_up_between_tracking_parts() -> None:
    sources = {
        **SOURCES,
        f"{TRACKING}.runs.finalise": (
            SOURCES[f"{TRACKING}.runs.finalise"][0]
            + "\n\ndef f():\n    from lwrlab.tracking.lifecycle import job_run\n",
            False,
        ),
    }
    found = tracking_part_violations(package_graph(TRACKING, sources))
    assert len(found) == 1 and found[0].startswith(f"{TRACKING}.runs imports {TRACKING}.lifecycle"), found
    assert [frozenset({"runs", "lifecycle"})] == cycles(package_graph(TRACKING, sources))


# --- lwrlab.pipeline's parts: one sub-package per task, shared modules below, the chain on top -----

PIPELINE = "lwrlab.pipeline"
_SHARED = ("config_nodes", "config_checks", "build")
PIPELINE_PARTS: dict[str, SubPackage] = {
    part.name: part
    for part in (
        SubPackage("config_nodes", (), "reading config nodes is the bottom: every task uses it"),
        SubPackage("config_checks", ("config_nodes",), "checking a config needs no task"),
        SubPackage("build", (), "the configured objects of a job need no task"),
        SubPackage(
            "identification",
            _SHARED,
            "identification is the base the other tasks build on: it knows none of them",
        ),
        SubPackage("excitation", _SHARED, "an exciting motion is designed before anything is identified"),
        SubPackage(
            "tools", (*_SHARED, "identification"), "tools build on identification, not on the uses of tools"
        ),
        SubPackage(
            "monitor",
            (*_SHARED, "identification", "tools"),
            "monitoring reads models and logs; no task reads monitoring",
        ),
        SubPackage(
            "live",
            (*_SHARED, "identification", "tools", "monitor", "painting"),
            "the live tasks run the monitor and the painting controller beside a robot over ROS 2; "
            "no task reads them",
        ),
        SubPackage(
            "painting",
            (*_SHARED, "identification", "tools", "excitation"),
            "the painting chain uses identification and tools; only the chain and its live form use it",
        ),
        SubPackage(
            "studies",
            (*_SHARED, "identification", "excitation", "tools"),
            "studies repeat the tasks below them; no task depends on a study",
        ),
        SubPackage(
            "chain",
            (*_SHARED, "identification", "excitation", "tools", "monitor", "painting", "studies"),
            "the paper chain runs the tasks in turn: the top",
        ),
    )
}
"""The arrows between the parts of :mod:`lwrlab.pipeline`; the package's ``__init__`` may name any."""


def test_pipeline_is_grouped_by_task_in_sub_packages_that_say_what_they_own() -> None:
    folder = REPOSITORY / "lwrlab" / "pipeline"
    modules = {path.stem for path in folder.glob("*.py") if path.name != "__init__.py"}
    parts = {path.parent.name for path in folder.glob("*/__init__.py")}
    assert modules | parts == set(PIPELINE_PARTS), "every part of the pipeline has a rule, every rule a part"
    assert modules <= {"chain", *_SHARED}, "a task's modules live in its sub-package"
    for part in parts:
        docstring = ast.get_docstring(ast.parse((folder / part / "__init__.py").read_text()))
        assert docstring and len(docstring) > 80, f"{PIPELINE}.{part}/__init__.py: say what the part owns"


def test_pipeline_parts_import_only_the_parts_below() -> None:
    found = part_violations(PIPELINE, PIPELINE_PARTS, package_graph(PIPELINE, SOURCES))
    assert not found, "\n".join(found)


def test_the_checker_finds_an_arrow_up_between_pipeline_parts() -> None:
    module = f"{PIPELINE}.identification.report"
    sources = {
        **SOURCES,
        module: (SOURCES[module][0] + "\n\ndef f():\n    from lwrlab.pipeline.tools import bench\n", False),
    }
    found = part_violations(PIPELINE, PIPELINE_PARTS, package_graph(PIPELINE, sources))
    assert len(found) == 1 and found[0].startswith(f"{PIPELINE}.identification imports {PIPELINE}.tools"), (
        found
    )
