"""Packages meet through their public surface: what each package's ``__init__`` lists in
``__all__`` (``docs/architecture.md``, "Packages and their floors").

Read from the source, every ``import`` statement (those inside functions too): a module of
one top-level package (``schemas``, ``simhost``, ``plugins``, ``orchestrator``), or of the
code that uses them as a team or an operator would (``examples/``, ``deploy/``), must not
import another package's underscore module (``simhost.host._records``) or a name its module
does not list in ``__all__``. Tests may reach inside (they test the insides) and are not
read.

The imports that still do are listed in ``KNOWN``, by the file that must change; the list
only shrinks: a new violation fails, and so does an entry that no longer occurs (remove
it). Every name a known violation imports is already exported by a public package, so each
fix is a change of module path (``test_every_known_violation_has_a_public_way``).
"""

from __future__ import annotations

import ast
import importlib
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("schemas", "simhost", "plugins", "orchestrator")
#: Code beside the packages that uses them from outside, as a team or an operator does.
CONSUMERS = ("examples", "deploy")
#: The packages whose ``__all__`` is a declared surface: each must have one, and each name
#: in it must resolve.
SURFACES = (
    "schemas",
    "simhost",
    "simhost.client",
    "simhost.client.skills",
    "simhost.host",
    "simhost.worlds",
    "simhost.worlds.assets",
    "simhost.worlds.sanity",
    "simhost.worlds.track1",
    "simhost.worlds.track2",
    "plugins",
    "plugins.sanity",
    "plugins.track1",
    "plugins.track2",
    "orchestrator",
)
#: Private names whose public name differs: private name → public ``module.name``.
RENAMED = {
    "simhost.worlds.track2._picture._resize": "simhost.worlds.track2.resize_rgb",
}

#: Imports across packages that do not go through the surface yet: the file that must
#: change → what it imports (an underscore module, or ``module.name`` not in ``__all__``).
#: Only shrinks; empty now: a new crossing fails at once.
KNOWN: dict[str, tuple[str, ...]] = {}


@dataclass(frozen=True)
class Crossing:
    """One import across packages that goes around the surface."""

    file: str
    line: int
    target: str
    """The underscore module imported from, or ``module.name`` missing from ``__all__``."""
    names: tuple[str, ...]
    """What the statement imports from ``target``'s module (empty for a module import)."""
    module: str
    """The module the statement imports from."""


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _source_of(module: str) -> Path | None:
    base = REPO.joinpath(*module.split("."))
    for path in (base / "__init__.py", base.with_suffix(".py")):
        if path.is_file():
            return path
    return None


@cache
def declared(module: str) -> tuple[str, ...] | None:
    """The literal ``__all__`` of a module of this repository (``None``: it has none)."""
    path = _source_of(module)
    if path is None:
        return None
    names: list[str] | None = None
    for node in ast.parse(path.read_text(), str(path)).body:
        if isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if not any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                continue
            assert isinstance(node.value, ast.List | ast.Tuple), \
                f"{path.relative_to(REPO)}: __all__ must be a literal list of names"
            found = [ast.literal_eval(e) for e in node.value.elts]
            names = found if names is None or not isinstance(node, ast.AugAssign) \
                else names + found
    return None if names is None else tuple(names)


def _is_submodule(module: str, name: str) -> bool:
    return not _private(name) and _source_of(f"{module}.{name}") is not None


def _sources() -> Iterator[Path]:
    for root in PACKAGES + CONSUMERS:
        yield from (p for p in sorted((REPO / root).rglob("*.py")) if "build" not in p.parts)


def _crossings(source: str, file: str) -> Iterator[Crossing]:
    """The crossings of one file's source (``file``: its path in the repository, whose first
    folder is the package it belongs to)."""
    here = file.split("/")[0]
    for node in ast.walk(ast.parse(source, file)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] not in PACKAGES or parts[0] == here:
                    continue
                for k, part in enumerate(parts):
                    if _private(part):
                        yield Crossing(file, node.lineno, ".".join(parts[:k + 1]), (),
                                       alias.name)
                        break
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            parts = node.module.split(".")
            if parts[0] not in PACKAGES or parts[0] == here:
                continue
            names = tuple(a.name for a in node.names)
            private = next((k for k, part in enumerate(parts) if _private(part)), None)
            if private is not None:
                yield Crossing(file, node.lineno, ".".join(parts[:private + 1]), names,
                               node.module)
                continue
            public = declared(node.module)
            for name in names:
                if _private(name):  # ``from schemas import _protocol``
                    yield Crossing(file, node.lineno, f"{node.module}.{name}", (), node.module)
                elif (public is None or name not in public) \
                        and not _is_submodule(node.module, name):
                    yield Crossing(file, node.lineno, f"{node.module}.{name}", (name,),
                                   node.module)


@cache
def all_crossings() -> tuple[Crossing, ...]:
    return tuple(c for path in _sources()
                 for c in _crossings(path.read_text(), path.relative_to(REPO).as_posix()))


def public_way(module: str, name: str) -> str | None:
    """Where ``name`` (imported from ``module``) is public: the nearest package above
    ``module`` whose ``__all__`` lists it, as ``package.name``."""
    renamed = RENAMED.get(f"{module}.{name}")
    if renamed is not None:
        return renamed
    parts = module.split(".")
    for k in range(len(parts), 0, -1):
        package = ".".join(parts[:k])
        if any(_private(p) for p in parts[:k]):
            continue
        if name in (declared(package) or ()):
            return f"{package}.{name}"
    return None


def _hint(c: Crossing) -> str:
    ways = [public_way(c.module, n) for n in c.names]
    if c.names and all(ways):
        return "import " + ", ".join(f"`{w}`" for w in ways if w)
    if not c.names:
        return "import the names it uses from a package that lists them in __all__"
    missing = [n for n, w in zip(c.names, ways, strict=True) if w is None]
    return (f"no package lists {', '.join(missing)} in __all__: add it to the __all__ of "
            f"the package that owns it, then import it from there")


def test_imports_across_packages_go_through_the_public_surface() -> None:
    found = {(c.file, c.target) for c in all_crossings()}
    known = {(file, target) for file, targets in KNOWN.items() for target in targets}
    new = [c for c in all_crossings() if (c.file, c.target) not in known]
    stale = sorted(known - found)
    lines = [f"{c.file}:{c.line} imports {c.target}: {_hint(c)}" for c in new]
    lines += [f"KNOWN lists {file}: {target}, which it no longer imports: remove the entry "
              f"from tests/test_public_surface.py" for file, target in stale]
    assert not lines, "imports around the public surface:\n" + "\n".join(lines)


def test_every_known_violation_has_a_public_way() -> None:
    """Each name a listed import takes is exported already: the owner changes only the
    module path. (Whole underscore modules imported, ``from schemas import _protocol``, are
    left out: the names used from them are attributes, read where they are used.)"""
    missing = [f"{c.file}:{c.line}: {c.module}.{name}" for c in all_crossings()
               for name in c.names if public_way(c.module, name) is None]
    assert not missing, "no package exports:\n" + "\n".join(missing)


@pytest.mark.parametrize("package", SURFACES)
def test_each_package_declares_its_surface_and_every_name_resolves(package: str) -> None:
    names = declared(package)
    assert names is not None, f"{package} has no __all__: list what other packages may import"
    assert len(set(names)) == len(names), f"{package}.__all__ names something twice"
    module = importlib.import_module(package)
    assert tuple(module.__all__) == names
    unresolved = [n for n in names if not hasattr(module, n)]
    assert not unresolved, f"{package}.__all__ names what it does not have: {unresolved}"


def test_the_check_sees_what_it_should() -> None:
    """The reader catches each kind of crossing, inside a function too, and nothing else."""
    source = ("from schemas._io import ignored_note\n"
              "from schemas import _protocol\n"
              "from schemas import WorldModel, not_exported\n"
              "from simhost import client\n"
              "def f() -> None:\n"
              "    import simhost.host._records\n"
              "    from plugins._base import TrackPlugin\n")
    got = [(c.line, c.target) for c in _crossings(source, "plugins/probe.py")]
    assert got == [(1, "schemas._io"), (2, "schemas._protocol"),
                   (3, "schemas.not_exported"), (6, "simhost.host._records")]
