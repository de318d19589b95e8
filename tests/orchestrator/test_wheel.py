"""The eagc wheel the agent base installs, built without a build backend (issue 10 §1).

Real pip installs it (no index, no build step) into a folder, and a separate Python
process imports the agent client from there and finds the tracks' entry points.
"""

from __future__ import annotations

import base64
import csv
import hashlib
import io
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from orchestrator._images.build import ImageBuildError, _run
from orchestrator._images.wheel import WheelError, build_wheel

REPO = Path(__file__).resolve().parents[2]


def test_the_wheel_is_reproducible_and_its_record_is_true(tmp_path: Path) -> None:
    one = build_wheel(REPO, tmp_path / "a").read_bytes()
    two = build_wheel(REPO, tmp_path / "b").read_bytes()
    assert one == two
    z = zipfile.ZipFile(io.BytesIO(one))
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    info = f"eagc-{version}.dist-info"
    rows = list(csv.reader(io.StringIO(z.read(f"{info}/RECORD").decode())))
    assert {r[0] for r in rows} == set(z.namelist())
    for path, digest, size in rows:
        if path.endswith("RECORD"):
            continue
        data = z.read(path)
        want = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        assert digest == f"sha256={want}" and int(size) == len(data), path


def test_the_wheel_holds_every_module_and_the_json_schemas(tmp_path: Path) -> None:
    names = set(zipfile.ZipFile(build_wheel(REPO, tmp_path)).namelist())
    for package in ("schemas", "simhost", "plugins", "orchestrator"):
        for path in (REPO / package).rglob("*.py"):
            if "__pycache__" in path.parts or not (path.parent / "__init__.py").is_file():
                continue
            assert path.relative_to(REPO).as_posix() in names
    for path in (REPO / "schemas" / "json").glob("*.json"):
        assert path.relative_to(REPO).as_posix() in names
    assert not any(n.startswith(("tests/", "examples/", "deploy/")) for n in names)


def test_pip_installs_it_without_an_index_and_the_client_imports(tmp_path: Path) -> None:
    wheel = build_wheel(REPO, tmp_path / "wheels")
    target = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index",
                        "--no-build-isolation", "-q", "--target", str(target), str(wheel)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (target / "bin" / "eagc").is_file()  # the console script
    probe = (
        "import importlib.metadata as m, simhost.client, schemas, sys\n"
        f"assert simhost.client.__file__.startswith({str(target)!r}), simhost.client.__file__\n"
        "d = m.distribution('eagc')\n"
        "print(sorted(e.name for e in d.entry_points if e.group == 'eagc.tracks'))\n"
        "print(sorted(r.split(';')[0].split('>')[0] for r in d.requires if ';' not in r))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(target)}
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                       env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    tracks, base = r.stdout.splitlines()
    assert eval(tracks) == sorted(project["entry-points"]["eagc.tracks"])  # noqa: S307
    assert eval(base) == sorted(d.split(">")[0] for d in project["dependencies"])  # noqa: S307


def test_an_unknown_build_setting_is_named(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "x"\nversion = "1"\ndynamic = ["readme"]\n')
    with pytest.raises(WheelError, match="dynamic"):
        build_wheel(tmp_path, tmp_path / "out")


def test_a_failed_build_step_is_one_line(tmp_path: Path) -> None:
    """pip's own failure (here: a package no index has, with no index at all) becomes one
    line naming the step and pip's error; the whole output stays in ``detail``."""
    with pytest.raises(ImageBuildError) as e:
        _run([sys.executable, "-m", "pip", "download", "--no-index", "-q", "-d", str(tmp_path),
              "no-such-package-for-eagc"], "downloading the client's wheels")
    message = str(e.value)
    assert "\n" not in message
    assert message.startswith("downloading the client's wheels failed (python")
    assert "no-such-package-for-eagc" in message
    assert "no-such-package-for-eagc" in e.value.detail
