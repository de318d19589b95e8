"""A public API that keeps its word: one version, and a changelog that names every change to
the generated protocol page and JSON Schemas (issue 31 §5).

``CHANGELOG.md`` names each generated file with its fingerprint, the first 12 hex digits of
its sha256: `` `world_model.json` (sha256 `0123456789ab`) ``. The newest line naming a file
(sections run newest first) must carry the file's fingerprint today, so a change to the file
fails here until a line in the changelog's top section says what changed for teams.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import re
import tomllib
from pathlib import Path

from typer.testing import CliRunner

import orchestrator
import schemas
from orchestrator.cli import app

REPO = Path(__file__).resolve().parents[1]
CHANGELOG = REPO / "CHANGELOG.md"
GENERATED = (REPO / "schemas" / "PROTOCOL.md", *sorted((REPO / "schemas" / "json").glob("*.json")))
_NAMED = re.compile(r"`(?P<name>[^`\s]+)`\s+\(sha256\s+`(?P<digest>[0-9a-f]{12})`\)")


def fingerprint(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:12]


def newest_fingerprints(text: str) -> dict[str, str]:
    """File name → the fingerprint of the first (newest) line that names it."""
    out: dict[str, str] = {}
    for m in _NAMED.finditer(text):
        out.setdefault(m["name"], m["digest"])
    return out


def _version() -> str:
    return str(tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"])


def _sections(text: str) -> list[str]:
    return re.findall(r"^## \[([^\]]+)\]", text, flags=re.MULTILINE)


def test_the_changelog_names_every_change_to_the_generated_files() -> None:
    named = newest_fingerprints(CHANGELOG.read_text())
    top = _sections(CHANGELOG.read_text())[0]
    wrong = []
    for path in GENERATED:
        now = fingerprint(path)
        if named.get(path.name) != now:
            wrong.append(
                f"{path.relative_to(REPO)} changed (sha256 {now}) and CHANGELOG.md does not "
                f"say so: add under '## [{top}]' a line saying what changed for teams, "
                f"naming `{path.name}` (sha256 `{now}`)")
    assert not wrong, "\n".join(wrong)


def test_the_fingerprint_reader() -> None:
    text = ("## [0.3.0]\n- `a.json` (sha256 `111111111111`): a field added\n"
            "## [0.2.0]\n- `a.json` (sha256\n  `222222222222`), `b.json` (sha256 `333333333333`)\n")
    assert newest_fingerprints(text) == {"a.json": "111111111111", "b.json": "333333333333"}


def test_one_version_everywhere_and_a_section_for_it() -> None:
    version = _version()
    installed = importlib.metadata.version("eagc")
    assert installed == version, (f"the installed metadata says {installed}, pyproject.toml "
                                  f"{version}: reinstall (pip install -e .)")
    assert schemas.__version__ == orchestrator.__version__ == version
    sections = _sections(CHANGELOG.read_text())
    assert version in sections, f"CHANGELOG.md has no '## [{version}]' section"
    assert sections[0] in (version, "Unreleased"), \
        f"the newest section of CHANGELOG.md is {sections[0]}, older than {version}"


def test_eagc_version_prints_it() -> None:
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"eagc {_version()}"
