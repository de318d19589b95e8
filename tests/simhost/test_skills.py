"""The public Track 1 skills (``simhost.client.skills``, docs/skills.md): light enough for a team's
container, built from the agent's own observations only, one copy shared with the Track 1
baselines, and, through the real host (SimHost over Zenoh, the episode worker, a local
process), a symbolic agent built only on them completes dev episodes while a skill's
failure comes back with the host's own reason."""

from __future__ import annotations

import ast
import json
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._images.build import CLIENT_SOURCES
from orchestrator._images.wheel import build_wheel
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeResult, EpisodeStatus, Limits

ROOT = Path(__file__).resolve().parents[2]
SKILLS = ROOT / "simhost" / "skills"
SYMBOLIC = ROOT / "examples" / "track1_symbolic" / "agent.py"
PROBE = Path(__file__).with_name("_skills_probe.py")
HEAVY = ("mujoco", "ray", "docker", "gymnasium", "mcap", "orchestrator", "plugins")
LIMITS = Limits(time_scale=0.25, startup_s=60.0)


def _modules_after(code: str) -> list[str]:
    probe = (f"{code}\nimport json, sys\n"
             "print(json.dumps(sorted(k for k, v in sys.modules.items() if v is not None)))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    return json.loads(out.stdout.splitlines()[-1])


def test_the_skills_import_nothing_heavy_nor_a_simulator() -> None:
    modules = _modules_after("import sys\nsys.modules['gymnasium'] = None\n"
                             "import simhost.client.skills\n"
                             "from simhost.client.skills import Skills")
    assert not [m for m in modules if m.split(".")[0] in HEAVY]
    assert not [m for m in modules if m.startswith(("simhost.worlds", "simhost.host"))]


def test_the_skills_read_only_what_the_host_sends() -> None:
    """Their imports: the standard library, numpy and the client (``simhost.client`` and its
    ``_remote``), nothing of a simulator, a track or the organizer's side."""
    allowed = {"simhost.client", "simhost.client._remote", "simhost._errors"}
    for path in sorted(SKILLS.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                top = name.split(".")[0]
                if top == "simhost":
                    assert name in allowed or name.startswith("simhost.client.skills"), (path, name)
                else:
                    assert top in sys.stdlib_module_names | {"numpy", "__future__"}, (
                        path, name)


def test_the_client_wheel_and_the_agent_base_carry_the_skills(tmp_path: Path) -> None:
    """The wheel installed in ``eagc/agent-base`` holds every skills module, and a change to
    one rebuilds that image (its hash covers ``CLIENT_SOURCES``)."""
    wheel = build_wheel(ROOT, tmp_path)
    names = set(zipfile.ZipFile(wheel).namelist())
    for path in SKILLS.glob("*.py"):
        assert f"simhost/client/skills/{path.name}" in names, path.name
    code = ("import json, sys, simhost.client.skills\n"
            "print(json.dumps([m.__file__ for k, m in sorted(sys.modules.items())\n"
            "                  if k.startswith('simhost') and getattr(m, '__file__', None)]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    covered = [ROOT / p for p in CLIENT_SOURCES]
    for f in map(Path, json.loads(out.stdout.splitlines()[-1])):
        assert any(f == c or c in f.parents for c in covered), (
            f"{f.relative_to(ROOT)} is imported by simhost.client.skills but not in CLIENT_SOURCES")


def test_the_baselines_hold_no_copy_of_the_skills() -> None:
    """One copy: the map, the model, navigation and the instruction reader live in
    simhost.client.skills; the Track 1 library and baselines import them from there."""
    library = ROOT / "examples" / "track1_common"
    assert not {"mapping.py", "model.py", "skills.py"} & {p.name for p in library.iterdir()}
    for folder in ("track1_common", "track1_heuristic", "track1_lookahead",
                   "track1_structured", "track1_symbolic"):
        for path in (ROOT / "examples" / folder).glob("*.py"):
            text = path.read_text()
            for old in ("mapping", "model", "skills"):
                assert f"from {old} import" not in text, (path, old)
    symbolic = SYMBOLIC.read_text()
    assert "track1_common" not in symbolic and "sys.path" not in symbolic
    assert (SYMBOLIC.parent / "Dockerfile").read_text().count("FROM eagc/agent-base:latest")


def _run(agent: Path, seed: int, runs: Path, split: str = "dev") -> EpisodeResult:
    spec = EpisodeSpec(track="track1", image=f"{sys.executable} {agent}", seed=seed,
                       split=split, limits=LIMITS, runs_dir=runs, exit_grace_s=10.0)
    return run_episode(spec, LocalProcessRuntime(quiet=True))


@pytest.fixture(scope="module")
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="t1s-", dir="/tmp"))  # short: unix socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 3])
def test_the_symbolic_agent_completes_dev_episodes(seed: int, runs: Path) -> None:
    """Dev seed 1 relocates the item (found again by searching), seed 3 makes the named
    container unavailable (another one of the room takes it): the task holds at the end,
    and the exception is detected."""
    result = _run(SYMBOLIC, seed, runs)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.stages_reached == ("exploration", "planning", "execution")
    assert {f.name for f in result.files if f.ok} == {"world_model.json", "episode_log.jsonl"}
    assert result.score.metrics["task_success"] == 1.0, result.score.metrics
    assert result.score.metrics["recovery"] == 1.0, result.score.metrics
    assert result.score.metrics["model_verification"] > 0.8, result.score.metrics


@pytest.mark.slow
def test_a_skill_fails_with_the_hosts_reason_and_acts_when_it_can(
        runs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "probe.json"
    monkeypatch.setenv("SKILLS_PROBE_OUT", str(out))
    result = _run(PROBE, 2, runs)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    got = json.loads(out.read_text())
    assert got["stage"] == "execution"
    assert got["go_to_room"]["status"] == "done"
    # What the host refuses comes back with the host's own reason, as it gave it.
    for skill, reason in (("pick_table", "not_pickable"), ("open_table", "not_openable")):
        outcome = got[skill]
        assert outcome["status"] == "failed" and outcome["by_host"], outcome
        assert outcome["reason"] == got[f"{skill}_host"] == reason, (outcome, got)
        assert outcome["steps"] >= 1
    # The skills' own reasons, without a step.
    assert got["place_unheld"] == {"status": "failed", "reason": "not_holding",
                                   "by_host": False, "steps": 0,
                                   "target": got["place_unheld"]["target"],
                                   "locked": [], "unavailable": []}
    assert got["unknown"]["reason"] == "not_in_model" and got["unknown"]["steps"] == 0
    # And what it can do, it does.
    assert got["fetch"]["status"] == "done" and got["held"] == got["item"], got
    assert got["place"]["status"] == "done" and got["held_after"] == -1, got
