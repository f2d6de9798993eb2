"""The package's structure, as docs/architecture.md writes it: layers, and no import cycles.

Every import counts: at module level, inside functions and under `TYPE_CHECKING`, since each
is a dependency of the code even when it is deferred.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import networkx as nx

REPO_ROOT = Path(__file__).resolve().parents[1]
PACKAGE = REPO_ROOT / "hubero_dsl"
ARCHITECTURE = REPO_ROOT / "docs" / "architecture.md"


def _modules() -> dict[str, Path]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(REPO_ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = path
    return found


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The hubero_dsl modules a file imports (`from a.b import c` counts c when c is a module)."""
    targets: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{alias.name}" for alias in node.names]
            names = [n if n in modules else node.module for n in names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name.startswith("hubero_dsl."):
                targets.add(name)
    return targets


def _import_graph() -> nx.DiGraph:
    modules = _modules()
    graph = nx.DiGraph()
    for name, path in modules.items():
        graph.add_node(name)
        for target in _imports(path, modules):
            if target != name and not name.startswith(target + "."):  # a package's own modules
                graph.add_edge(name, target)
    return graph


def _layers() -> dict[str, int]:
    """package -> layer, from the table in docs/architecture.md."""
    layers = {}
    for number, packages in re.findall(r"^\| (\d+) \| ([^|]+) \|", ARCHITECTURE.read_text(),
                                       flags=re.M):
        for package in re.findall(r"`([a-z_]+)`", packages):
            layers[package] = int(number)
    return layers


def _package(module: str) -> str:
    return module.split(".")[1]


def test_no_module_imports_itself_through_others() -> None:
    cycles = list(nx.simple_cycles(_import_graph()))
    assert cycles == [], cycles


def test_every_package_has_a_layer() -> None:
    layers = _layers()
    packages = {_package(m) for m in _import_graph() if m.count(".") >= 1}
    assert packages - {"__main__"} <= set(layers), sorted(packages - set(layers))


def test_packages_import_only_lower_layers() -> None:
    layers = _layers()
    wrong = []
    for source, target in _import_graph().edges:
        low, high = _package(target), _package(source)
        if high == "__main__" or low == high:
            continue
        if layers[low] >= layers[high]:
            wrong.append(f"{source} ({layers[high]}) imports {target} ({layers[low]})")
    assert wrong == [], "\n".join(wrong)


def test_nothing_after_the_compiler_reads_the_syntax_tree() -> None:
    readers = {source for source, target in _import_graph().edges
               if _package(target) == "lang" and _package(source) != "lang"}
    assert readers == {"hubero_dsl.pipeline"}


def test_checking_a_scenario_imports_no_distance_fields_or_trees() -> None:
    # scipy.ndimage and scipy.spatial took a cold `hubero check` from 0.5 s to 0.7 s: a
    # scenario whose bodies fit and do not overlap is checked without either
    root = Path(__file__).resolve().parents[1]
    probe = ("import sys\n"
             "from hubero_dsl.pipeline import check_file\n"
             f"for name in ('living_room', 'parking', 'robot_among_guests'):\n"
             f"    assert check_file({str(root / 'scenarios')!r} + f'/{{name}}.hub').program\n"
             "print(sorted(m for m in ('scipy.ndimage', 'scipy.spatial') if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
