"""The Track 1 baselines (examples/track1_*): they share one copy of their library
(examples/track1_common, the image they are built FROM, on simhost.client.skills), they run
through the real episode worker (SimHost over Zenoh, MCAP, /output collection, scoring) as
local processes, and the calibration benchmark's in-process harness scores an episode
exactly as the worker does.

The agents run WITHOUT the sandbox here (``LocalProcessRuntime``, development only); each runs
in its container in ``tests/orchestrator/test_track1_docker.py``. The calibration itself
(Table IV on many seeds) is ``tests/benchmarks/bench_track1_fidelity.py``, not a test.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeResult, EpisodeStatus, Limits, WorldModel, load_json

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
BASELINES = ("track1_sanity", "track1_memoryfree", "track1_heuristic", "track1_lookahead",
             "track1_structured")
LIBRARY = EXAMPLES / "track1_common"
"""The baselines' shared modules: one copy, in the image ``eagc/track1-common``."""
ON_LIBRARY = ("track1_memoryfree", "track1_heuristic", "track1_lookahead", "track1_structured")
"""The baselines built FROM the library's image (the sanity baseline needs none of it)."""
LIMITS = Limits(max_steps_per_stage=60, time_scale=0.2, startup_s=60.0)


def _from(folder: Path) -> str:
    return next(line for line in (folder / "Dockerfile").read_text().splitlines()
                if line.startswith("FROM"))


def _modules(folder: Path) -> list[Path]:
    return [*folder.glob("*.py"), *folder.glob("*.npz")]


def test_every_baseline_has_its_image_and_readme() -> None:
    assert _from(LIBRARY) == "FROM eagc/agent-base:latest"
    assert not (LIBRARY / "agent.py").exists(), "the library is not an agent"
    for name in BASELINES:
        folder = EXAMPLES / name
        parent = "track1-common" if name in ON_LIBRARY else "agent-base"
        assert _from(folder) == f"FROM eagc/{parent}:latest", name
        assert (folder / "agent.py").is_file(), f"{name} has no agent.py"
    for folder in (LIBRARY, *(EXAMPLES / name for name in BASELINES)):
        dockerfile = (folder / "Dockerfile").read_text()
        assert (folder / "README.md").is_file(), f"{folder.name} has no README"
        copied = [line for line in dockerfile.splitlines() if line.startswith("COPY")]
        for module in _modules(folder):  # the image has them all
            assert any(module.name in line or f"*{module.suffix}" in line for line in copied), (
                f"{folder.name}'s Dockerfile does not copy {module.name}")
        # What runs in the image needs numpy and the light client only (training does not
        # run there: train_*.py run offline, with the simulator).
        text = "\n".join(p.read_text() for p in folder.glob("*.py")
                         if not p.name.startswith("train_"))
        for heavy in ("torch", "mujoco", "ray", "docker", "gymnasium", "plugins", "scipy"):
            assert f"import {heavy}" not in text and f"from {heavy}" not in text, (
                folder.name, heavy)


def test_each_library_module_has_one_copy() -> None:
    """A baseline built on the library holds none of its modules: one copy of each, and
    none that its image's ``COPY`` would write over the library's in /app."""
    library = {m.name for m in _modules(LIBRARY)}
    assert {"planner.py", "lookahead.py", "priors.py", "priors.npz"} <= library
    # The map, the model, navigation and the instruction reader are simhost.client.skills'
    # (tests/simhost/test_skills.py).
    assert not {"mapping.py", "model.py", "skills.py", "parsing.py"} & library
    for name in BASELINES:
        mine = {m.name for m in _modules(EXAMPLES / name)}
        assert not mine & library, f"examples/{name} has a copy of {sorted(mine & library)}"


@pytest.mark.parametrize("name", ON_LIBRARY)
def test_each_baseline_imports_the_library_from_a_checkout(name: str, tmp_path: Path) -> None:
    """Run as a local process (``python examples/<name>/agent.py``: --runtime local, the
    benchmarks' children), an agent finds the library in the sibling folder by itself."""
    code = ("import json, os, runpy, sys; sys.path.insert(0, os.path.dirname(sys.argv[1])); "
            "runpy.run_path(sys.argv[1], run_name='not_main'); "  # as `python agent.py`
            "print(json.dumps({m: sys.modules[m].__file__ for m in "
            "('entry', 'planner', 'lookahead', 'parsing', 'priors', 'simhost.client.skills') "
            "if m in sys.modules}))")
    out = subprocess.run([sys.executable, "-c", code, str(EXAMPLES / name / "agent.py")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    loaded = json.loads(out.stdout.splitlines()[-1])
    assert "entry" in loaded, loaded  # every one plays through the library's entry point
    # ... and reads the instruction with simhost.client.skills' reader.
    assert "simhost.client.skills" in loaded, loaded
    skills = loaded.pop("simhost.client.skills")
    assert Path(skills).parent == ROOT / "simhost" / "client" / "skills", skills
    assert all(Path(f).parent == LIBRARY for f in loaded.values()), loaded


def _run(agent: str, split: str, seed: int, runs: Path, limits: Limits = LIMITS
         ) -> EpisodeResult:
    spec = EpisodeSpec(track="track1", image=f"python {EXAMPLES / agent / 'agent.py'}",
                       seed=seed, split=split, limits=limits, runs_dir=runs, exit_grace_s=10.0)
    return run_episode(spec, LocalProcessRuntime(quiet=True))


@pytest.fixture(scope="module")
def runs() -> Iterator[Path]:
    folder = Path(tempfile.mkdtemp(prefix="t1b-", dir="/tmp"))  # short: unix socket paths
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.slow
# The host releases its rendering context when it stops serving: closing the episode's
# renderer from another thread raised EGL_BAD_ACCESS in its destructor before.
@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.parametrize("agent", BASELINES)
def test_each_baseline_plays_a_short_episode_through_the_worker(agent: str, runs: Path) -> None:
    """Each baseline plays (60 steps a stage): the random sanity agent meets the contract;
    every other maps the house while exploring (a world model the score verifies well
    above nothing), logs a plan, and the map planners make progress on the task."""
    result = _run(agent, "standard", 5, runs)
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.stages_reached == ("exploration", "planning", "execution")
    assert {f.name for f in result.files if f.ok} == {"world_model.json", "episode_log.jsonl"}
    if agent == "track1_sanity":
        return
    out = Path(result.episode_dir or "") / "host" / "output"
    model = load_json(out / "world_model.json", WorldModel)
    assert len(model.rooms) >= 2 and model.connections, "no map of the house"
    assert result.score.metrics["model_verification"] > 0.3, result.score.metrics
    events = {json.loads(line)["event"] for line in
              (out / "episode_log.jsonl").read_text().splitlines()}
    assert "plan" in events, events
    if agent != "track1_memoryfree":  # the policy without a map needs longer to fetch
        assert result.score.components["task"] > 0.0, result.score.components


def _load(folder: Path) -> ModuleType:
    """An example's agent module, imported under a private name with its folder first."""
    sys.path.insert(0, str(folder))
    try:
        spec = importlib.util.spec_from_file_location(f"_agent_{folder.name}",
                                                      folder / "agent.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(folder))


@pytest.mark.slow
def test_the_in_process_harness_scores_as_the_worker_does(runs: Path) -> None:
    """The calibration benchmark runs the same agent code in process: same episode, same
    steps, same score as through SimHost, Zenoh and the worker's collection and scoring."""
    sys.path.insert(0, str(ROOT / "tests" / "benchmarks"))
    from _track1_harness import run_agent

    limits = Limits(max_steps_per_stage=150, time_scale=1.0, startup_s=60.0)
    real = _run("track1_heuristic", "standard", 7, runs, limits)
    agent = _load(EXAMPLES / "track1_heuristic")
    local = run_agent(lambda ep: agent.Agent(), "standard", 7, max_steps_per_stage=150)
    assert local.error == "", local.error
    assert local.steps == real.stats.steps
    assert local.invalid_actions == real.stats.invalid_actions
    assert local.card.total == pytest.approx(real.score.total, abs=1e-9)
    assert local.card.components == pytest.approx(real.score.components, abs=1e-9)


def test_memoryfree_look_alike_tables_are_the_tracks() -> None:
    """The memory-free policy's look-alike tables are copies (its image cannot import the
    simulator): they must say what the track's detector does, for every object and tool."""
    from simhost.worlds.track1 import CONFUSABLE, CONFUSABLE_COLOURS
    from simhost.worlds.track1._catalogue import OBJECT_CATEGORIES, TOOL_CATEGORIES

    agent = _load(EXAMPLES / "track1_memoryfree")
    items = (*OBJECT_CATEGORIES, *TOOL_CATEGORIES)
    assert agent.LOOKALIKE == {k: v for k, v in CONFUSABLE.items() if k in items}
    assert agent.LOOKALIKE_COLOURS == CONFUSABLE_COLOURS


def test_memoryfree_reports_the_doorways_it_passes_and_only_real_ones() -> None:
    """The memory-free policy writes the doorways it passes between two signed rooms into its
    report (write-only: it never reads it back). Every connection it reports is an edge of
    the true room graph, and exploration finds some."""
    sys.path.insert(0, str(ROOT / "tests" / "benchmarks"))
    from _track1_harness import run_agent

    agent = _load(EXAMPLES / "track1_memoryfree")
    episodes: list[Any] = []

    def make(episode: object) -> object:
        episodes.append(episode)
        return agent.Agent()

    reported = 0
    for seed in range(3):
        played = run_agent(make, "standard", seed, render=False)
        assert played.error == "", played.error
        model = played.snapshots["exploration"]["world_model.json"]
        edges = {frozenset(c.rooms) for c in episodes[-1].gt_exploration.connections}
        for c in model.connections:
            assert frozenset(int(r) for r in c.rooms) in edges, (seed, c)
        reported += len(model.connections)
    assert reported > 0


def test_memoryfree_answers_the_queries_from_what_houses_are_like() -> None:
    """Without a map the memory-free policy answers from its learned tables, over the rooms
    the queries' texts name: every answer is well-formed, a room it names is one of those,
    and over a few houses it does clearly better than leaving them unanswered (0), without
    reaching what a model of the house answers (about 3/4)."""
    from plugins import load_track
    from plugins.track1._queries import grade, to_send
    from plugins.track1._types import Track1Scenario

    agent = _load(EXAMPLES / "track1_memoryfree")
    plugin = load_track("track1")
    scores = []
    for seed in range(6):
        scenario = plugin.make_scenario(seed=seed, split="standard",
                                        params={"render_rgbd": False})
        spec = Track1Scenario.model_validate(scenario.params)
        episode = plugin.make_episode(scenario)
        try:
            episode.reset()
            truth = episode.env.ground_truth()  # type: ignore[attr-defined]
        finally:
            episode.close()
        sent = to_send(spec.queries, ())
        answers = agent.Answers(agent.Priors())
        rooms = answers.named_rooms(sent)
        assert rooms and set(rooms.values()) <= {r.type for r in truth.rooms}
        given = {q["id"]: a for q in sent if (a := answers.answer(q, rooms, {})) is not None}
        for q in sent:
            if q["kind"] == "object_room":
                assert given[q["id"]] in rooms
            if q["kind"] in ("door_state", "container_state"):
                assert given[q["id"]] in ("open", "closed")
        scores += [g.score for g in grade(spec.queries, given, truth)]
    assert 0.25 < sum(scores) / len(scores) < 0.7
