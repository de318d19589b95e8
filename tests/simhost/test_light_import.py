"""A team's container needs only pydantic, eclipse-zenoh and numpy (docs/architecture.md).

The quick check looks at ``sys.modules`` after the agent-side imports. The strong check
builds this repository's wheel, installs it without dependencies into a fresh venv that sees
only the light packages (no system site-packages), and plays an episode against a real host
from there.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import venv
import zipfile
from email.parser import Parser
from importlib.metadata import distribution
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
HEAVY_PACKAGES = ("mujoco", "ray", "docker", "gymnasium", "mcap")
HEAVY = (*HEAVY_PACKAGES, "orchestrator", "plugins")  # nothing organizer-side either
LIGHT_DISTRIBUTIONS = (
    "pydantic",
    "pydantic-core",
    "annotated-types",
    "typing-extensions",
    "typing-inspection",
    "eclipse-zenoh",
    "numpy",
)


def _imported_after(code: str) -> list[str]:
    probe = (f"{code}\nimport json, sys\n"
             "print(json.dumps(sorted(k for k, v in sys.modules.items() if v is not None)))")
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return json.loads(out.stdout.splitlines()[-1])


def _heavy(modules: list[str], heavy: tuple[str, ...] = HEAVY) -> list[str]:
    return sorted(m for m in modules if m.split(".")[0] in heavy)


_CLIENT = ("import simhost, simhost.client\n"
           "from simhost.client import HostError, RemoteEnv, TimeStep")


@pytest.mark.parametrize("gymnasium", ["installed", "absent"])
def test_agent_client_imports_nothing_heavy(gymnasium):
    # Absent as in a team's container (an import of it fails). Installed, the environments
    # register only once gymnasium is imported: the client imports neither it nor a track.
    block = "import sys\nsys.modules['gymnasium'] = None\n" if gymnasium == "absent" else ""
    modules = _imported_after(block + _CLIENT)
    assert not _heavy(modules), "simhost.client must stay light (team containers import it)"
    assert not [m for m in modules if m.startswith(("simhost.worlds", "simhost.host"))]


_GYM_CLIENT = _CLIENT + "\nfrom simhost.client import GymEnv, StageEnd, StageRule"


@pytest.mark.parametrize("gymnasium", ["installed", "absent"])
def test_the_gymnasium_style_client_imports_gymnasium_only_when_installed(gymnasium):
    # Absent (the agent base image): plain spaces, nothing heavy. Installed: gymnasium (and
    # the light track registrations it triggers), still no simulator, organizer or runtime.
    block = "import sys\nsys.modules['gymnasium'] = None\n" if gymnasium == "absent" else ""
    modules = _imported_after(block + _GYM_CLIENT)
    heavy = _heavy(modules)
    if gymnasium == "absent":
        assert not heavy
        assert not [m for m in modules if m.startswith(("simhost.worlds", "simhost.host"))]
    else:
        assert {m.split(".")[0] for m in heavy} == {"gymnasium"}


def test_schemas_import_only_pydantic():
    modules = _imported_after("import schemas")
    assert not _heavy(modules, (*HEAVY, "numpy", "zenoh", "simhost"))


_AGENT = textwrap.dedent(
    """
    import importlib.util, json, sys
    missing = [m for m in {heavy!r} if importlib.util.find_spec(m) is None]
    import simhost.client
    from simhost.client import RemoteEnv

    env = RemoteEnv(sys.argv[1], sys.argv[2], timeout_s=20)
    env.hello(agent="light/1")
    env.reset()
    ts = env.step({{"velocity": [0.5, 0.0]}})
    while not ts.episode_over:
        ts = env.end_stage()
    env.close()
    print(json.dumps({{"missing": missing, "modules": sorted(sys.modules),
                      "agent_file": simhost.client.__file__, "prefix": sys.prefix,
                      "end": ts.end_reason}}))
    """
)


@pytest.mark.slow
def test_agent_runs_with_only_the_base_dependencies(tmp_path, host_episode):
    # 1. The wheel of this repository, built from a copy (the work tree is left alone).
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        if (ROOT / name).exists():
            shutil.copy(ROOT / name, src / name)
    for pkg in ("schemas", "simhost", "plugins", "orchestrator"):
        if (ROOT / pkg).is_dir():
            shutil.copytree(ROOT / pkg, src / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    dist = tmp_path / "dist"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    # Without PYTHONPATH: pip would take a work tree on it (its eagc.egg-info) for eagc
    # already installed, and leave the fresh venv without it.
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "--no-index",
                    "-w", str(dist), str(src)], check=True, capture_output=True, env=clean)
    (wheel,) = dist.glob("eagc-*.whl")
    with zipfile.ZipFile(wheel) as z:
        meta = Parser().parsestr(z.read(next(n for n in z.namelist()
                                             if n.endswith(".dist-info/METADATA"))).decode())
    base = sorted(r.split(">")[0].split("=")[0].split("<")[0].strip()
                  for r in meta.get_all("Requires-Dist") or [] if "extra ==" not in r)
    assert base == ["eclipse-zenoh", "numpy", "pydantic"], "the base install must stay light"

    # 2. A fresh venv (no system site-packages) with the wheel and the light packages only.
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False, system_site_packages=False, symlinks=True)
    python = env_dir / "bin" / "python"
    subprocess.run([*pip, "--python", str(python), "install", "--no-deps", "--no-index",
                    str(wheel)], check=True, capture_output=True, env=clean)
    site = Path(subprocess.run(
        [str(python), "-I", "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        check=True, capture_output=True, text=True,
    ).stdout.strip())
    for name in LIGHT_DISTRIBUTIONS:
        d = distribution(name)
        for top in {f.parts[0] for f in d.files or ()} - {"..", "__pycache__"}:
            origin = Path(d.locate_file(top))
            assert origin.exists(), origin
            (site / top).symlink_to(origin)

    # 3. An episode against a real host, from inside that venv.
    out = subprocess.run(
        [str(python), "-I", "-c", _AGENT.format(heavy=HEAVY_PACKAGES), host_episode.endpoint,
         host_episode.episode],
        capture_output=True, text=True, timeout=60, cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    report = json.loads(out.stdout.splitlines()[-1])
    missing = sorted(report["missing"])
    assert missing == sorted(HEAVY_PACKAGES), "the venv must not see heavy packages"
    assert report["agent_file"].startswith(report["prefix"]), "simhost came from elsewhere"
    assert not _heavy(report["modules"])
    assert report["end"] == "completed"
    outcome = host_episode.outcome()
    assert (outcome.end_reason, outcome.steps) == ("completed", 1)
