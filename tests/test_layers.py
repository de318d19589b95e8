"""Imports point down: orchestrator → plugins → simhost → schemas, with no circle.

Read from the source (every ``import`` statement, also those inside functions), so a new
import that runs back up, or a circle between two of the orchestrator's rooms, fails here
before anyone has to draw the house to see it.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Lowest floor first: a package may import those below it, never those above.
FLOORS = ("schemas", "simhost", "plugins", "orchestrator")
#: The orchestrator's rooms, lowest first (``_errors`` is the floor under all of them).
ROOMS = ("_errors", "_programs", "_runtimes", "_results", "_images", "_episode", "_campaign",
         "_viewer", "_channel", "conformance", "cli")


def _module(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> Iterator[tuple[str, int]]:
    """Every module ``path`` imports (absolute name) with its line, relative ones resolved."""
    here = _module(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[: len(package) - node.level + 1] + [base]).strip(".")
            yield base, node.lineno
            for alias in node.names:  # ``from orchestrator import _x`` names a module
                yield f"{base}.{alias.name}", node.lineno


def _sources() -> list[Path]:
    return [p for floor in FLOORS for p in sorted((REPO / floor).rglob("*.py"))]


def test_every_import_points_down() -> None:
    up = []
    for path in _sources():
        mine = FLOORS.index(_module(path).split(".")[0])
        for name, line in _imports(path):
            top = name.split(".")[0]
            if top in FLOORS and FLOORS.index(top) > mine:
                up.append(f"{path.relative_to(REPO)}:{line} imports {name}")
    assert not up, "imports that run back up:\n" + "\n".join(up)


def _room(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == "orchestrator" and len(parts) > 1 else None


def test_the_orchestrators_rooms_point_down() -> None:
    known = {p.name.removesuffix(".py") for p in (REPO / "orchestrator").iterdir()
             if p.name != "__init__.py" and not p.name.startswith(".")
             and (p.suffix == ".py" or (p / "__init__.py").is_file())}
    assert known == set(ROOMS), "a room was added or removed: place it in ROOMS"
    up = []
    for path in sorted((REPO / "orchestrator").rglob("*.py")):
        mine = _room(_module(path))
        if mine is None:
            continue
        for name, line in _imports(path):
            theirs = _room(name)
            if theirs in ROOMS and ROOMS.index(theirs) > ROOMS.index(mine):
                up.append(f"{path.relative_to(REPO)}:{line} imports {name}")
    assert not up, "imports that run back up between rooms:\n" + "\n".join(up)


def test_no_module_imports_itself_in_a_circle() -> None:
    """Module-level imports only (an import inside a function runs later and cannot
    deadlock the loading; the floors above still hold for those)."""
    modules = {_module(p): p for p in _sources()}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Import):
                found = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                subs = [f"{node.module}.{a.name}" for a in node.names]
                found = [s for s in subs if s in modules] or [node.module]
            else:
                continue
            # A module's own packages are loaded before it: not a circle.
            graph[name].update(f for f in found if f in modules
                               and f != name and not name.startswith(f + "."))
    state: dict[str, int] = {}

    def visit(m: str, trail: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                pytest.fail("circle: " + " -> ".join(trail[trail.index(n):] + [m, n])
                            if n in trail else f"circle through {m} -> {n}")
            if n not in state:
                visit(n, trail + [m])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])
