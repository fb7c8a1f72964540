"""The house rules of docs/design.md, checked on the code's own imports (every module's AST):

- the layer table (``LAYERS``, and ``APP_LAYERS`` inside ``app/``) as data: a unit imports only units
  of rows below its own, never up or sideways; a module in no unit (a new top-level module) must
  fit between the rows its importers and its imports stand in;
- no import circle between modules (a circle through a type annotation counts);
- function-level (deferred) imports in ``ftin/`` and ``app/`` only where ``DEFERRED`` gives the reason,
  at most 8;
- no file in ``ftin/`` or ``app/`` over 450 lines;
- docs/design.md draws the same rows and lists the same deferred imports.

The checker runs on any tree (``scan(root)``), so the tests below also show it failing on a planted
upward import, circle and deferred import.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ftin", "app", "experiments")
MAX_LINES = 450
MAX_DEFERRED = 8

# Top to bottom, as docs/design.md draws them. A unit is a module or a package (its dotted name); every
# module below a package belongs to it ("=name": that module alone, "name*": every name it starts). A row
# imports only rows below it.
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("entry", ("ftin.__main__",)),
    ("commands", ("ftin.cli", "experiments")),
    ("campaign", ("ftin.campaign",)),
    ("reports, app, benchmarks", ("ftin.report", "app", "ftin.bench")),
    ("evaluation, live", ("ftin.evaluate", "ftin.live", "ftin.analysis")),
    ("filter, training", ("ftin.filter", "ftin.train")),
    ("inference, uncertainty", ("ftin.infer", "ftin.uncertainty")),
    ("walkers", ("ftin.profiles",)),
    (
        "scoring, checkpoints, protocol",
        (
            "ftin.metrics",
            "ftin.checkpoint",
            "ftin.sim",
            "ftin.protocol",
            "ftin.yaw_average",
            "ftin.body_heading",
        ),
    ),
    ("foundations", ("ftin.models", "ftin.data", "ftin.files", "ftin.interrupts", "ftin.precision", "=ftin")),
]

# Inside app/: routes validate and call services; services know no API schema and no route.
APP_LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("entry", ("app.main", "app.serve")),
    ("routes", ("app.api",)),
    ("API bodies, scene", ("app.schemas*", "app.viz")),
    ("services", ("app.services",)),
    ("settings", ("app.settings", "=app")),
]

# Function-level imports, each with the reason it cannot stand at the top of its module:
# (importing module, imported module) -> why.
DEFERRED: dict[tuple[str, str], str] = {
    (
        "ftin.campaign.engine",
        "ray",
    ): "an optional extra ([cluster]); the CLI imports the engine without it (twice: "
    "``import_ray`` and the by-value Ray task)",
    ("ftin.campaign.engine", "ftin.campaign.job"): "the Ray task puts the job's frozen code first on the "
    "worker's path, then imports the job module from there",
    ("ftin.cli.bench", "ftin.cli.bench_app"): "the app (FastAPI, httpx, Playwright: the test extra) would "
    "add seconds to every ``ftin`` start",
    ("ftin.cli.campaign", "ftin.cli.table"): "importing it registers ``ftin table``: at the top it would "
    "change the order of ``ftin --help``",
    ("ftin.cli.common", "app.settings"): "only the walker-profile options need the app's default runs folder "
    "(pydantic-settings), not every ``ftin`` start",
    (
        "ftin.cli.profile",
        "app.services.stored_runs",
    ): "only ``ftin profile add`` reads a stored run (the app's archive and codec)",
    ("app.main", "app.viz.scene"): "viser loads only when the 3D scene is enabled",
}


@dataclass(frozen=True)
class Edge:
    source: str  # importing module
    target: str  # imported module (ours: the module; another package's: its dotted name)
    line: int
    deferred: bool  # inside a function

    def __str__(self) -> str:
        return f"{self.source}:{self.line} -> {self.target}"


def modules(root: Path) -> dict[str, Path]:
    """Every module of ``PACKAGES`` under ``root`` by dotted name (a package by its own name)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def _ours(name: str, known: dict[str, Path]) -> str:
    """The module of ours that ``name`` (a module or a name inside one) lives in."""
    while name not in known and "." in name:
        name = name.rpartition(".")[0]
    return name


def _imports(tree: ast.Module, module: str, is_package: bool, known: dict[str, Path]) -> list[Edge]:
    """The imports in ``tree``, with ``importlib.import_module("literal")`` calls."""
    package = module if is_package else module.rpartition(".")[0]
    deferred_nodes = set()
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            deferred_nodes.update(id(n) for n in ast.walk(fn) if n is not fn)
    edges = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            else:
                base = node.module or ""
            names = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names
            ]
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            names = [node.args[0].value]
        for name in dict.fromkeys(names):
            target = _ours(name, known) if name.split(".")[0] in PACKAGES else name
            edges.append(Edge(module, target, node.lineno, id(node) in deferred_nodes))
    return edges


def scan(root: Path) -> tuple[dict[str, Path], list[Edge]]:
    """The modules under ``root`` and every import among them or out of them."""
    known = modules(root)
    edges = []
    for module, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        edges += _imports(tree, module, path.name == "__init__.py", known)
    return known, edges


def _unit(module: str, table: list[tuple[str, tuple[str, ...]]]) -> tuple[str, int] | None:
    """The unit of ``table`` that ``module`` belongs to (the longest match) and its row; None: none."""
    best = None
    for row, (_label, units) in enumerate(table):
        for unit in units:
            if unit.endswith("*"):
                hit = module.startswith(unit[:-1])
            elif unit.startswith("="):
                hit = module == unit[1:]
            else:
                hit = module == unit or module.startswith(unit + ".")
            if hit and (best is None or len(unit) > len(best[0])):
                best = (unit, row)
    return best


def _scope(table: list[tuple[str, tuple[str, ...]]]) -> str:
    """The package a table speaks of: '' for the whole project, else its units' common package."""
    tops = {unit.strip("=*").split(".")[0] for _label, units in table for unit in units}
    return "" if len(tops) > 1 else tops.pop()


def upward_imports(
    known: dict[str, Path], edges: list[Edge], table: list[tuple[str, tuple[str, ...]]]
) -> list[str]:
    """Every import that points up or sideways in ``table``, and every module in no unit whose importers
    and imports leave it no row to stand between."""
    scope = _scope(table)
    inside = [
        e
        for e in edges
        if e.target in known and (not scope or e.source.split(".")[0] == scope == e.target.split(".")[0])
    ]
    problems = []
    unplaced: dict[str, tuple[list[int], list[int]]] = {}  # module -> rows of its importers, of its imports
    for edge in inside:
        source, target = _unit(edge.source, table), _unit(edge.target, table)
        if source and target:
            if source[0] != target[0] and target[1] <= source[1]:
                way = "sideways" if target[1] == source[1] else "up"
                problems.append(f"{edge}: {way} from {table[source[1]][0]!r} to {table[target[1]][0]!r}")
        elif source and not target:
            unplaced.setdefault(edge.target, ([], []))[0].append(source[1])
        elif target and not source:
            unplaced.setdefault(edge.source, ([], []))[1].append(target[1])
    for module, (above, below) in sorted(unplaced.items()):
        if above and below and max(above) >= min(below):
            problems.append(
                f"{module} is in no row of the table, and no row fits it: imported from row "
                f"{table[max(above)][0]!r}, it imports row {table[min(below)][0]!r} (add it to the table)"
            )
    return problems


def circles(known: dict[str, Path], edges: list[Edge]) -> list[list[str]]:
    """The import circles among our modules (strongly connected components of two or more, or one
    module importing itself), by Tarjan's algorithm."""
    graph: dict[str, set[str]] = {m: set() for m in known}
    for edge in edges:
        if edge.target in known:
            graph[edge.source].add(edge.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(start: str) -> None:
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1 or node in graph[node]:
                    found.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return found


def deferred_imports(edges: list[Edge]) -> dict[tuple[str, str], list[Edge]]:
    """The function-level imports of ``ftin/`` and ``app/`` (a probe in ``experiments/`` is a script run
    once: its imports are its own business)."""
    found: dict[tuple[str, str], list[Edge]] = {}
    for edge in edges:
        if edge.deferred and edge.source.split(".")[0] in ("ftin", "app"):
            found.setdefault((edge.source, edge.target), []).append(edge)
    return found


def long_files(root: Path) -> list[str]:
    found = []
    for package in ("ftin", "app"):
        for path in sorted((root / package).rglob("*.py")):
            lines = len(path.read_text(encoding="utf-8").splitlines())
            if lines > MAX_LINES:
                found.append(f"{path.relative_to(root)}: {lines} lines")
    return found


@pytest.fixture(scope="module")
def tree() -> tuple[dict[str, Path], list[Edge]]:
    return scan(ROOT)


@pytest.mark.parametrize("table", [LAYERS, APP_LAYERS], ids=["project", "app"])
def test_no_import_points_up(tree, table):
    known, edges = tree
    assert upward_imports(known, edges, table) == []


def test_every_unit_of_the_tables_exists(tree):
    known, _edges = tree
    for table in (LAYERS, APP_LAYERS):
        for _label, units in table:
            for unit in units:
                name = unit.strip("=*")
                assert any(m == name or m.startswith(name) for m in known), f"{unit}: no such module"


def test_no_import_circle(tree):
    known, edges = tree
    assert circles(known, edges) == []


def test_deferred_imports_are_the_allowed_ones(tree):
    _known, edges = tree
    found = deferred_imports(edges)
    unexplained = [str(e) for key, es in found.items() if key not in DEFERRED for e in es]
    assert unexplained == [], "a function-level import without a reason in DEFERRED (or move it up)"
    assert sorted(set(DEFERRED) - set(found)) == [], "DEFERRED names an import that is gone"
    assert sum(len(es) for es in found.values()) <= MAX_DEFERRED


def test_no_file_over_the_line_limit():
    assert long_files(ROOT) == []


def _diagram_lines(design: str) -> list[str]:
    section = design.split("## The layers", 1)[1]
    return section.split("```text", 1)[1].split("```", 1)[0].splitlines()


def _shown_as(unit: str, root: Path) -> str:
    """How design.md writes a unit: ``ftin/cli/``, ``ftin/evaluate.py``, ``experiments/``."""
    path = root / unit.replace(".", "/")
    return f"{unit.replace('.', '/')}/" if path.is_dir() else f"{unit.replace('.', '/')}.py"


def test_design_md_draws_the_table():
    """Every unit of ``LAYERS`` stands in design.md's diagram, the rows in the table's order."""
    lines = _diagram_lines((ROOT / "docs" / "design.md").read_text(encoding="utf-8"))
    last = -1
    for label, units in LAYERS:
        shown = [u for u in units if not u.startswith("=")]  # a package's face is not drawn
        at = []
        for unit in shown:
            token = _shown_as(unit, ROOT)
            rows = [i for i, line in enumerate(lines) if re.search(rf"(^|\s){re.escape(token)}", line)]
            assert rows, f"{token} ({label}) is missing from design.md's layer diagram"
            at.append(rows[0])
        assert min(at) > last, f"design.md draws row {label!r} above a row the table puts over it"
        last = max(at)


def test_design_md_lists_the_deferred_imports():
    design = (ROOT / "docs" / "design.md").read_text(encoding="utf-8")
    for module, target in DEFERRED:
        assert f"{module} -> {target}" in design, (
            f"design.md does not list the deferred import {module} -> {target}"
        )


# --- the checker fails where it should ---------------------------------------------------------------


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


MINI = {
    "ftin/__init__.py": "",
    "ftin/cli/__init__.py": "",
    "ftin/cli/main.py": "from ftin.data.types import Seq\n",
    "ftin/data/__init__.py": "",
    "ftin/data/types.py": "class Seq: ...\n",
    "app/__init__.py": "",
    "experiments/__init__.py": "",
}


def test_checker_passes_a_tree_that_follows_the_layers(tmp_path):
    _write(tmp_path, MINI)
    known, edges = scan(tmp_path)
    assert upward_imports(known, edges, LAYERS) == []
    assert circles(known, edges) == []


def test_checker_fails_on_a_planted_upward_import(tmp_path):
    _write(tmp_path, {**MINI, "ftin/data/types.py": "from ftin.cli import main\n\nclass Seq: ...\n"})
    known, edges = scan(tmp_path)
    problems = upward_imports(known, edges, LAYERS)
    assert problems == ["ftin.data.types:1 -> ftin.cli.main: up from 'foundations' to 'commands'"]
    assert circles(known, edges) == [["ftin.cli.main", "ftin.data.types"]]


def test_checker_fails_on_an_upward_edge_in_the_real_tree(tree):
    known, edges = tree
    planted = Edge("ftin.data.types", "ftin.filter.session", 1, deferred=True)
    assert upward_imports(known, [*edges, planted], LAYERS) == [
        "ftin.data.types:1 -> ftin.filter.session: up from 'foundations' to 'filter, training'"
    ]
    assert deferred_imports([*edges, planted]).keys() - DEFERRED.keys() == {
        ("ftin.data.types", "ftin.filter.session")
    }


def test_checker_fails_on_a_sideways_import_and_a_circle_through_a_type(tmp_path):
    _write(
        tmp_path,
        {
            **MINI,
            "ftin/train/__init__.py": "from ftin.filter import F\n",
            "ftin/filter/__init__.py": (
                "from typing import TYPE_CHECKING\n\n"
                "if TYPE_CHECKING:\n    from ftin.filter.b import B\n\nF = 1\n"
            ),
            "ftin/filter/b.py": "from ftin.filter import F\n\nclass B: ...\n",
        },
    )
    known, edges = scan(tmp_path)
    assert upward_imports(known, edges, LAYERS) == [
        "ftin.train:1 -> ftin.filter: sideways from 'filter, training' to 'filter, training'"
    ]
    assert circles(known, edges) == [["ftin.filter", "ftin.filter.b"]]


def test_a_new_module_fits_where_its_imports_let_it(tmp_path):
    """A new top-level module (not in the table) passes where a row fits between its importers and its
    imports, and fails where none does."""
    fits = {
        **MINI,
        "ftin/heading.py": "from ftin.data.types import Seq\n",
        "ftin/cli/h.py": "import ftin.heading\n",
    }
    _write(tmp_path / "fits", fits)
    assert upward_imports(*scan(tmp_path / "fits"), LAYERS) == []
    stuck = {
        **fits,
        "ftin/heading.py": "from ftin.cli.main import x\n",
        "ftin/data/h.py": "import ftin.heading\n",
    }
    _write(tmp_path / "stuck", stuck)
    problems = upward_imports(*scan(tmp_path / "stuck"), LAYERS)
    assert len(problems) == 1 and problems[0].startswith("ftin.heading is in no row of the table")


def test_checker_counts_a_long_file(tmp_path):
    _write(tmp_path, {**MINI, "ftin/data/long.py": "x = 1\n" * (MAX_LINES + 1)})
    assert long_files(tmp_path) == [f"ftin/data/long.py: {MAX_LINES + 1} lines"]
