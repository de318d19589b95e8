"""Near-miss shapes of a Track 1 world model and an exception never detected: each is a
note that names what was found and, for a shape, the shape eagc reads with the model's
own example; the same sentence on the score card, in ``eagc check-files`` and on the
episode's page. The fixtures are ours, in the shapes a team wrote before eagc existed
(issue 35): rooms as names, room links under ``topology[].frontiers[]``, doors and
containers filed as objects with states as ``{entity, attribute, value}`` triples,
affordances as ``{object, actions}``.
"""

from __future__ import annotations

import html
import json
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

from plugins import load_track
from schemas import (
    Affordance,
    ContainerState,
    DoorState,
    EpisodeStatus,
    FileProblems,
    Limits,
    LogRecord,
    Room,
    WorldModel,
    parse_json,
)
from tests.plugins.test_track1_scoring import _exc, _input, _planned, outcome, perfect_model

AGENT = Path(__file__).resolve().parent / "team_shapes_agent.py"

#: A world model in the team's shapes, beside entries in ours (the kept ones).
TEAM: dict[str, Any] = {
    "episode_id": "ep-7", "agent_state": {"current_room": "hall", "step": 40},
    "rooms": ["hall", "kitchen", {"id": 2, "type": "bedroom"}],
    "topology": [{"room": "hall", "visited": True,
                  "frontiers": [{"target": "kitchen", "via": 4, "status": "open"},
                                {"target": "bedroom", "status": "closed"}]},
                 {"room": "kitchen", "frontiers": []}],
    "objects": [{"id": 11, "category": "mug", "room": 1, "position": [2.0, 1.0],
                 "name": "mug"},
                {"id": 4, "category": "object", "name": "door", "state": "closed"},
                {"id": 30, "category": "fridge", "room": 1, "state": "observed"},
                {"id": "drawer_2", "category": "object", "room": 1}],
    "states": [{"entity": 4, "attribute": "state", "value": "closed"},
               {"entity": "mug", "attribute": "location", "value": "counter"}],
    "affordances": [{"object": "knife", "actions": ["cut(bread)"]},
                    {"tool": 12, "affordance": "cut"}],
}
LOG = (b'{"step": 0, "event_type": "observation"}\n'
       b'{"step": 1, "event_type": "perception"}\n')


def example(model: type[BaseModel]) -> str:
    """The model's own example, as the notes print it."""
    extra = model.model_config.get("json_schema_extra")
    assert isinstance(extra, dict) and isinstance(extra["examples"], list)
    return json.dumps(extra["examples"][0], separators=(", ", ": "))


def _notes(model: WorldModel) -> dict[str, str]:
    from plugins.track1._score import shape_notes

    return {n.split(":")[0]: n for n in shape_notes(model)}


def test_each_near_miss_shape_is_noted_with_the_shape_eagc_reads() -> None:
    model = parse_json(json.dumps(TEAM), WorldModel, source="world_model.json")
    notes = _notes(model)
    assert set(notes) == {"rooms", "topology[].frontiers", "states", "affordances",
                          "objects"}, notes
    assert notes["rooms"].startswith(
        'rooms: 2 of 3 entries are names, not objects ("hall", "kitchen"): left out')
    assert notes["rooms"].endswith(f"eagc reads rooms: [{example(Room)}]")
    assert notes["topology[].frontiers"].startswith(
        "topology[].frontiers: 2 of 2 entries are room links under topology, a key "
        'eagc does not read ({"target": "kitchen", "via": 4, "status": "open"}')
    assert '"rooms": [3, 5]' in notes["topology[].frontiers"]
    assert notes["states"].startswith(
        "states: 2 of 2 entries are {entity, attribute, value} triples")
    assert notes["states"].endswith(f"eagc reads doors: [{example(DoorState)}] and "
                                    f"containers: [{example(ContainerState)}]")
    assert notes["affordances"].startswith(
        "affordances: 1 of 2 entries are {object, actions}, not a tool and an "
        'affordance ({"object": "knife", "actions": ["cut(bread)"]}): left out')
    assert notes["affordances"].endswith(f"affordances: [{example(Affordance)}]")
    assert notes["objects"].startswith(
        'objects: 3 of 4 entries are doors or containers (4, 30, "drawer_2")')
    # what is left out is gone, what is ours is kept and graded
    assert [r.id for r in model.rooms] == [2]
    assert [(a.tool, a.affordance) for a in model.affordances] == [(12, "cut")]
    assert [o.id for o in model.objects] == [11, 4, 30, "drawer_2"]
    # each key said once: the keys a near-miss note explains are not listed as ignored
    from schemas._io import ignored_fields

    ignored = ignored_fields(model)
    assert "topology" not in ignored and "states" not in ignored
    assert "episode_id" in ignored and "objects.0.name" in ignored


def test_a_model_in_our_shapes_has_no_near_miss_note() -> None:
    assert _notes(perfect_model()) == {}
    model = parse_json(perfect_model().model_dump_json(), WorldModel, source="w")
    assert model.near_miss_notes() == () and _notes(model) == {}


def test_check_files_passes_the_file_and_shows_each_note_with_its_values() -> None:
    _, checks = load_track("track1").verify_files({
        "world_model.json": json.dumps(TEAM).encode(), "episode_log.jsonl": LOG})
    by = {c.name: c for c in checks}
    assert by["world_model.json"].ok, by["world_model.json"].reason
    lines = by["world_model.json"].reason.splitlines()
    model = parse_json(json.dumps(TEAM), WorldModel, source="world_model.json")
    for note in _notes(model).values():
        assert note in lines, (note, lines)
    assert not any("did you mean" in x for x in lines), lines


def test_a_refused_file_still_names_its_near_misses_after_what_fails() -> None:
    broken = {**TEAM, "doors": [{"id": 4, "state": "ajar"}]}
    with pytest.raises(FileProblems) as e:
        parse_json(json.dumps(broken), WorldModel, source="world_model.json")
    failing = e.value.failing
    assert failing[0].startswith("doors.0.state:"), failing
    assert any(x.startswith("rooms: 2 of 3 entries are names") for x in failing)
    assert any(x.startswith("affordances: 1 of 2 entries") for x in failing)
    assert not any(x.startswith("affordances.0") for x in failing), \
        "left out, not reported as a missing tool"


def test_the_card_says_the_same_sentences_and_the_model_still_scores() -> None:
    model = parse_json(json.dumps(TEAM), WorldModel, source="world_model.json")
    card = load_track("track1").score(_input(outcome(), model=model))
    for note in _notes(model).values():
        assert f"world_model.json: {note}" in card.notes, (note, card.notes)
    assert sum(n.startswith("world_model.json: rooms:") for n in card.notes) == 1


def _relocated(effect: int | None) -> Any:
    return outcome(exception={**_exc("object_relocation", 10, step=60, effect=effect),
                              "details": {"receptacle": 21}},
                   planned_exception=_planned("object_relocation"), steps=200)


def _card_notes(o: Any, *claims: int) -> tuple[str, ...]:
    log = [LogRecord(step=s, event="exception_detected",
                     exception_type="object_relocation") for s in claims]
    return load_track("track1").score(_input(o, model=perfect_model(), log=log,
                                             steps=200)).notes


def test_a_relocation_never_detected_is_noted() -> None:
    notes = _card_notes(_relocated(70))
    (note,) = [n for n in notes if "never detected" in n]
    assert note.startswith("object_relocation at step 60 (item 10 put away in 21) "
                           "never detected: no exception_detected record of type "
                           "object_relocation in steps 60-100; its first effect the "
                           "agent could see came at step 70"), note
    unseen = [n for n in _card_notes(_relocated(None)) if "never detected" in n]
    assert "in steps 60-230; nothing the agent saw showed it" in unseen[0], unseen
    # detected in time: no note; late: the late note alone
    assert not [n for n in _card_notes(_relocated(70), 80) if "never detected" in n]
    late = _card_notes(_relocated(70), 150)
    assert not [n for n in late if "never detected" in n]
    assert any("after the window" in n for n in late), late


@pytest.fixture(scope="module")
def team_episode() -> Iterator[Path]:
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._runtimes.local import LocalProcessRuntime

    plugin = load_track("track1")
    planned = plugin.hidden(plugin.make_scenario(seed=1, split="dev", params={}))
    assert planned.exception is not None
    assert planned.exception.type == "object_relocation"
    runs = Path(tempfile.mkdtemp(prefix="eagc-nm-", dir="/tmp"))  # short: unix sockets
    result = run_episode(EpisodeSpec(
        track="track1", image=f"{sys.executable} {AGENT}", seed=1, split="dev",
        params={"render_rgbd": False}, runs_dir=runs,
        limits=Limits(startup_s=60.0, pin_cpus=False)), LocalProcessRuntime(quiet=True))
    yield Path(result.episode_dir or "")
    shutil.rmtree(runs, ignore_errors=True)


@pytest.mark.slow
def test_files_in_the_team_shapes_complete_with_every_loss_named(
        team_episode: Path, tmp_path: Path) -> None:
    from orchestrator._viewer.site import write_episode_site
    from schemas import EpisodeResult

    result = EpisodeResult.model_validate_json(
        (team_episode / "host" / "result.json").read_text())
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    by = {f.name: f for f in result.files}
    assert by["world_model.json"].ok and by["episode_log.jsonl"].ok
    said = [x for x in by["world_model.json"].reason.splitlines()
            if x.split(":")[0] in ("rooms", "topology[].frontiers", "states",
                                   "affordances", "objects")]
    assert len(said) == 5, by["world_model.json"].reason
    notes = result.score.notes
    for line in said:  # one sentence, on the card and in the check
        assert f"world_model.json: {line}" in notes, (line, notes)
    assert any(n.startswith("object_relocation at step ") and "never detected" in n
               for n in notes), notes
    assert any(n.startswith("episode_log.jsonl: ") and "'execution_exception', not "
               "ours: write 'exception_detected'" in n for n in notes), notes
    page = write_episode_site(team_episode, tmp_path / "site")
    text = html.unescape("\n".join(p.read_text() for p in page if p.suffix == ".html"))
    for note in notes:
        assert note in text, note
