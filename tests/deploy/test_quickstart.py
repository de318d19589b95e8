"""The README's first command, in a brand-new virtual environment (issue 10 §1).

``python3 -m venv v && . v/bin/activate && bash deploy/quickstart.sh`` for real, in a copy
of the repository's tracked files (a fresh clone): a fresh venv (setuptools 65 and no
``wheel`` on Python 3.11), eagc installed into it by the script, images built offline, the
demo run (the sanity track only: the other tracks' demos run the same code), and then the
agent base image built from that venv's Python under a scratch tag, so that the wheel
build is exercised there even when the shared ``eagc/agent-base`` image is already up to
date. CI runs it (docker, slow); it costs about a minute on a 2-core machine once pip's
cache holds the dependencies (a cold cache downloads them once: Ray, MuJoCo and the rest,
a few hundred MB). The copy holds committed files only (``git ls-files``).
"""

from __future__ import annotations

import os
import secrets
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def engine() -> Any:
    from orchestrator._runtimes.docker import docker_client
    from orchestrator._runtimes.interface import InfraError

    try:
        return docker_client()
    except InfraError as e:
        if os.environ.get("CI"):
            pytest.fail(f"CI must have a Docker engine: {e}")
        pytest.skip(f"no Docker engine here ({e}); CI always has one")


@pytest.fixture()
def short_dir() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="eagc-qs-", dir="/tmp"))  # unix socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def _fresh_clone(dest: Path) -> Path:
    """The repository's tracked files (a fresh clone's), so that the editable install
    writes its build files there and not into the tree under test."""
    r = subprocess.run(["git", "-C", str(REPO), "ls-files", "-z"], capture_output=True)
    if r.returncode == 0 and r.stdout:
        for name in r.stdout.decode().split("\0"):
            if name and (REPO / name).is_file():
                (dest / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(REPO / name, dest / name)
    else:  # not a git checkout: the tree without what runs and builds leave behind
        shutil.copytree(REPO, dest, dirs_exist_ok=True, ignore=shutil.ignore_patterns(
            ".git", "runs", "build", "*.egg-info", "__pycache__", ".*_cache"))
    return dest


@pytest.mark.docker
@pytest.mark.slow
def test_quickstart_in_a_fresh_venv(engine: Any, tmp_path: Path, short_dir: Path) -> None:
    clone = _fresh_clone(tmp_path / "eagc")
    venv = tmp_path / "v"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(PATH=f"{venv / 'bin'}:{env.get('PATH', '')}", VIRTUAL_ENV=str(venv),
               COLUMNS="80")
    probe = subprocess.run([str(py), "-c", "import importlib.util as u; "
                            "print(u.find_spec('wheel') is None)"],
                           capture_output=True, text=True, env=env, check=True)
    assert probe.stdout.strip() == "True", "not a fresh venv: it has the wheel package"

    r = subprocess.run(["bash", str(clone / "deploy" / "quickstart.sh"), "--track", "sanity",
                        "--output", str(short_dir)], capture_output=True, text=True, env=env,
                       cwd=tmp_path, timeout=1200)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "Traceback" not in r.stderr
    assert "demo-sanity · sanity · phase local" in r.stdout and "sanity_agent" in r.stdout
    assert f"results of demo-sanity (SQLite, one row per episode):\n  {short_dir}/results.sqlite" \
        in r.stderr
    assert (short_dir / "demo_sanity.yaml").is_file()
    assert (venv / "bin" / "eagc").is_file()  # the venv's own eagc ran
    where = subprocess.run([str(py), "-c", "import orchestrator; print(orchestrator.__file__)"],
                           capture_output=True, text=True, env=env, cwd=tmp_path, check=True)
    assert where.stdout.strip().startswith(str(clone))  # installed from the clone

    # The wheel build from this venv, to a real image (a scratch tag: nobody else's).
    tag = f"eagc-test/agent-base-venv:{secrets.token_hex(4)}"
    build = ("from orchestrator._runtimes.docker import docker_client\n"
             "from orchestrator._images.build import build_agent_base\n"
             f"build_agent_base(docker_client(), say=print, force=True, tag={tag!r})\n")
    try:
        r = subprocess.run([str(py), "-c", build], capture_output=True, text=True, env=env,
                           cwd=tmp_path, timeout=900)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
        out = engine.containers.run(tag, ["python3", "-c", "import simhost.client, schemas; "
                                          "print(schemas.CONTAINER.uid)"],
                                    network_mode="none", remove=True)
        assert out.decode().strip() == "10001"
    finally:
        try:
            engine.images.remove(tag, force=True)
        except Exception:  # noqa: BLE001 - never built
            pass
