"""The code stays lint-clean and formatted (ruff, configured in pyproject.toml)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUFF = Path(sys.executable).with_name("ruff")


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=["check", "format"])
def test_ruff(command: list[str]) -> None:
    if not RUFF.exists():
        pytest.skip("ruff is not installed in this environment (scripts/setup.sh installs it)")
    done = subprocess.run(
        [str(RUFF), *command, "src", "tests"], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_mypy() -> None:
    """A bare ``mypy`` checks the packages under src/ (configured in pyproject.toml)."""
    mypy = Path(sys.executable).with_name("mypy")
    if not mypy.exists():
        pytest.skip("mypy is not installed in this environment (scripts/setup.sh installs it)")
    done = subprocess.run([str(mypy)], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def src_modules() -> dict[str, Path]:
    """Every module of the packages under src/ by dotted name (a package's ``__init__`` is the
    package's own name)."""
    modules: dict[str, Path] = {}
    for init in sorted((ROOT / "src").glob("*/*/__init__.py")):
        top = init.parent
        for path in sorted(top.rglob("*.py")):
            parts = path.relative_to(top.parent).with_suffix("").parts
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The modules of ``modules`` that ``name`` imports anywhere: at the top, under ``if
    TYPE_CHECKING:``, inside functions. ``from a.b import c`` is the module ``a.b.c`` when
    that is one, else ``a.b``; a name outside ``modules`` (numpy, ...) counts as its longest
    prefix inside them, if any."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: level 1 is this module's package
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            for alias in node.names:
                submodule = f"{base}.{alias.name}"
                targets.append(submodule if submodule in modules else base)
    found: set[str] = set()
    for target in targets:
        while target and target not in modules:
            target = target.rpartition(".")[0]
        if target and target != name:
            found.add(target)
    return found


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle of ``graph`` as ``[a, b, ..., a]``, or ``[]`` when it has none."""
    done: set[str] = set()
    path: list[str] = []
    on_path: set[str] = set()

    def visit(module: str) -> list[str]:
        path.append(module)
        on_path.add(module)
        for target in sorted(graph[module]):
            if target in on_path:
                return [*path[path.index(target) :], target]
            if target not in done and (cycle := visit(target)):
                return cycle
        on_path.discard(path.pop())
        done.add(module)
        return []

    for module in sorted(graph):
        if module not in done and (cycle := visit(module)):
            return cycle
    return []


def test_no_import_cycles() -> None:
    """No module under src/ imports itself back, not even only while type checking: a layer
    that a lower one needs (a config, a counter) belongs below both."""
    modules = src_modules()
    graph = {name: imported_modules(name, path, modules) for name, path in modules.items()}
    cycle = find_cycle(graph)
    assert cycle == [], "import cycle: " + " -> ".join(cycle)


#: The packages under src/, each building only on those before it: the interface, the
#: runtime, the model (fire, belief, aircraft), the batched world, training, the test
#: tools, the launch of a system, the benchmarks and the command line.
PACKAGE_ORDER = (
    "wildfire_msgs_py",
    "wildfire_ros",
    "wildfire_sim",
    "wildfire_belief",
    "wildfire_agent",
    "wildfire_world",
    "wildfire_learning",
    "wildfire_testbed",
    "wildfire_bringup",
    "wildfire_bench",
    "wildfire_cli",
)


def test_packages_import_only_the_packages_below_them() -> None:
    """Dependencies point one way, down :data:`PACKAGE_ORDER` (type-only imports included)."""
    modules = src_modules()
    assert sorted({name.partition(".")[0] for name in modules}) == sorted(PACKAGE_ORDER)
    rank = {package: i for i, package in enumerate(PACKAGE_ORDER)}
    upward = [
        f"{name} imports {target}"
        for name, path in modules.items()
        for target in sorted(imported_modules(name, path, modules))
        if rank[target.partition(".")[0]] > rank[name.partition(".")[0]]
    ]
    assert upward == []
