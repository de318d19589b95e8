"""The eagc wheel, built from ``pyproject.toml`` without a build backend (PEP 427).

The agent base image installs eagc from a wheel. Building it with ``pip wheel`` needs a
build backend: without build isolation, setuptools ≥ 70.1 or the ``wheel`` package in the
running Python (a fresh Python 3.11 venv has setuptools 65 and no ``wheel``:
``invalid command 'bdist_wheel'``); with isolation, a package index to download them from.
eagc is pure Python, so its wheel is a zip of the packages and three metadata files: this
module writes it from ``pyproject.toml`` itself, the same way in any venv, as root with the
system Python, or on a machine whose index is out of reach. It reads the fields eagc uses
(``[project]``: name, version, description, requires-python, license, dependencies,
optional-dependencies, scripts, entry-points; ``[tool.setuptools]``: packages.find
include patterns, package-data) and refuses any other build configuration by name, so a
change to ``pyproject.toml`` cannot be silently left out. The zip is reproducible: same
sources, same bytes.
"""

from __future__ import annotations

import base64
import fnmatch
import hashlib
import tomllib
import zipfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from orchestrator._errors import OrchestratorError

#: Every ``[project]`` key this builder understands (others: WheelError, by name).
PROJECT_KEYS = {"name", "version", "description", "readme", "requires-python", "license",
                "dependencies", "optional-dependencies", "scripts", "entry-points"}
SETUPTOOLS_KEYS = {"packages", "package-data"}
_EPOCH = (1980, 1, 1, 0, 0, 0)


class WheelError(OrchestratorError):
    """Raised when ``pyproject.toml`` asks for something this wheel builder does not do."""


def _normal(name: str) -> str:
    return name.replace("-", "_").replace(".", "_")


def _packages(root: Path, include: Iterable[str]) -> list[str]:
    """Dotted names of the folders with ``__init__.py`` matching an include pattern."""
    pats = list(include)
    found = []
    for init in sorted(root.rglob("__init__.py")):
        rel = init.parent.relative_to(root)
        if any(part.startswith(".") or part in ("build", "tests") for part in rel.parts):
            continue
        dotted = ".".join(rel.parts)
        if dotted and any(fnmatch.fnmatchcase(dotted, p) for p in pats):
            found.append(dotted)
    # A package is only importable if its parents are packages too.
    return [p for p in found if all(".".join(p.split(".")[:i]) in found
                                     for i in range(1, p.count(".") + 1))]


def _files(root: Path, packages: list[str], data: dict[str, list[str]]) -> list[Path]:
    out: set[Path] = set()
    for pkg in packages:
        folder = root / pkg.replace(".", "/")
        out.update(p for p in folder.glob("*.py") if p.is_file())
        for pattern in data.get(pkg, []):
            out.update(p for p in folder.glob(pattern) if p.is_file())
    return sorted(out)


def _metadata(project: dict[str, Any], root: Path) -> str:
    lines = ["Metadata-Version: 2.1", f"Name: {project['name']}",
             f"Version: {project['version']}"]
    if "description" in project:
        lines.append(f"Summary: {project['description']}")
    if "requires-python" in project:
        lines.append(f"Requires-Python: {project['requires-python']}")
    lic = project.get("license")
    if isinstance(lic, dict) and "text" in lic:
        lines.append(f"License: {lic['text']}")
    lines += [f"Requires-Dist: {d}" for d in project.get("dependencies", [])]
    for extra, deps in project.get("optional-dependencies", {}).items():
        lines.append(f"Provides-Extra: {extra}")
        lines += [f'Requires-Dist: {d}; extra == "{extra}"' for d in deps]
    body = ""
    readme = project.get("readme")
    if isinstance(readme, str) and (root / readme).is_file():
        lines.append("Description-Content-Type: text/markdown")
        body = "\n" + (root / readme).read_text()
    return "\n".join(lines) + "\n" + body


def _entry_points(project: dict[str, Any]) -> str:
    groups = {"console_scripts": project.get("scripts", {}),
              **project.get("entry-points", {})}
    out = []
    for group, eps in groups.items():
        if eps:
            out += [f"[{group}]", *(f"{k} = {v}" for k, v in eps.items()), ""]
    return "\n".join(out)


def _digest(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(
        b"=").decode()


def build_wheel(root: Path, dest: Path) -> Path:
    """Writes ``<name>-<version>-py3-none-any.whl`` of the project at ``root`` into
    ``dest`` and returns its path. WheelError names what cannot be built."""
    try:
        doc = tomllib.loads((root / "pyproject.toml").read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise WheelError(f"cannot read {root / 'pyproject.toml'}: {e}") from None
    project = doc.get("project", {})
    setuptools = doc.get("tool", {}).get("setuptools", {})
    unknown = sorted(set(project) - PROJECT_KEYS) + sorted(
        f"tool.setuptools.{k}" for k in set(setuptools) - SETUPTOOLS_KEYS)
    if "dynamic" in project or unknown:
        raise WheelError("pyproject.toml sets what the eagc wheel builder does not handle: "
                         f"{', '.join(unknown or ['dynamic'])} (orchestrator/_images/wheel.py)")
    find = setuptools.get("packages", {}).get("find", {})
    packages = _packages(root, find.get("include", ["*"]))
    if not packages:
        raise WheelError(f"no packages found under {root}")
    name, version = _normal(project["name"]), project["version"]
    info = f"{name}-{version}.dist-info"
    entries: list[tuple[str, bytes]] = [
        (f.relative_to(root).as_posix(), f.read_bytes())
        for f in _files(root, packages, setuptools.get("package-data", {}))
    ]
    entries += [
        (f"{info}/METADATA", _metadata(project, root).encode()),
        (f"{info}/WHEEL", b"Wheel-Version: 1.0\nGenerator: eagc\nRoot-Is-Purelib: true\n"
                          b"Tag: py3-none-any\n"),
        (f"{info}/entry_points.txt", _entry_points(project).encode()),
        (f"{info}/top_level.txt",
         "".join(f"{p}\n" for p in packages if "." not in p).encode()),
    ]
    record = "".join(f"{path},{_digest(data)},{len(data)}\n" for path, data in entries)
    entries.append((f"{info}/RECORD", (record + f"{info}/RECORD,,\n").encode()))
    dest.mkdir(parents=True, exist_ok=True)
    wheel = dest / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w", zipfile.ZIP_DEFLATED) as z:
        for path, data in entries:
            zi = zipfile.ZipInfo(path, date_time=_EPOCH)
            zi.external_attr = 0o644 << 16
            zi.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(zi, data)
    return wheel
