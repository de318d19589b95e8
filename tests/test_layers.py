"""Imports point down: orchestrator → plugins → simhost → schemas, with no circle.

Read from the source (every ``import`` statement, also those inside functions, relative
ones resolved), so a new import that runs back up, a circle between two of the
orchestrator's rooms, or a circle between any two modules fails here before anyone has to
draw the house to see it.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: Lowest floor first: a package may import those below it, never those above.
FLOORS = ("schemas", "simhost", "plugins", "orchestrator")
#: The orchestrator's rooms, lowest first (``_errors`` is the floor under all of them).
ROOMS = ("_errors", "_programs", "_runtimes", "_results", "_images", "_episode", "_campaign",
         "_viewer", "_channel", "conformance", "cli")


def _module(path: Path, root: Path = REPO) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path, root: Path = REPO) -> Iterator[tuple[str, int]]:
    """Every module ``path`` imports (absolute name) with its line, relative ones resolved."""
    here = _module(path, root).split(".")
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


def _sources(root: Path = REPO) -> list[Path]:
    return [p for floor in FLOORS for p in sorted((root / floor).rglob("*.py"))]


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


def _import_graph(root: Path = REPO) -> dict[str, dict[str, str]]:
    """Module → each module it imports → where (``path:line``): every import, those inside
    functions and relative ones too, and the packages an import loads on its way (``import
    a.b.c`` runs ``a`` and ``a.b`` first). A module's own packages are loaded before it:
    they are not edges."""
    modules = {_module(p, root): p for p in _sources(root)}
    graph: dict[str, dict[str, str]] = {m: {} for m in modules}
    for name, path in modules.items():
        for target, line in _imports(path, root):
            parts = target.split(".")
            for k in range(len(parts), 0, -1):  # the module named, then its packages
                found = ".".join(parts[:k])
                if found in modules and found != name and not name.startswith(found + "."):
                    graph[name].setdefault(found, f"{path.relative_to(root)}:{line}")
    return graph


def _circles(graph: dict[str, dict[str, str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(m: str) -> None:
        index[m] = low[m] = len(index)
        stack.append(m)
        for n in sorted(graph[m]):
            if n not in index:
                visit(n)
                low[m] = min(low[m], low[n])
            elif n in stack:
                low[m] = min(low[m], index[n])
        if low[m] == index[m]:
            part = stack[stack.index(m):]
            del stack[stack.index(m):]
            if len(part) > 1:
                out.append(sorted(part))

    for m in sorted(graph):
        if m not in index:
            visit(m)
    return out


def test_no_module_imports_itself_in_a_circle() -> None:
    """Counted honestly: an import inside a function closes a circle as surely as one at
    the top (it only runs later), so every import counts."""
    graph = _import_graph()
    found = [
        f"{' <-> '.join(part)}:\n" + "\n".join(
            f"  {m} -> {n} ({graph[m][n]})" for m in part for n in sorted(graph[m])
            if n in part)
        for part in _circles(graph)]
    assert not found, f"{len(found)} circle(s) between modules:\n" + "\n".join(found)


def test_the_circle_check_sees_imports_in_functions_and_relative_ones(tmp_path: Path) -> None:
    """The check above reads what it claims to: a circle closed by a relative import
    inside a function is one."""
    package = tmp_path / "plugins" / "toy"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from plugins.toy import b\n")
    (package / "b.py").write_text("def f() -> None:\n    from . import a\n")
    graph = _import_graph(tmp_path)
    assert graph["plugins.toy.b"] == {"plugins.toy.a": "plugins/toy/b.py:2"}, graph
    assert _circles(graph) == [["plugins.toy.a", "plugins.toy.b"]]
