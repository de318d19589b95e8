"""``simhost.host._records``: every record the MCAP recorder writes reads back as its model.

The recorder writes a small log by hand (no episode): each record kind comes back typed,
events by their ``event`` (an unknown one as ``OtherEvent`` with its fields in the order
written), and a log written in the earlier, hand-built JSON (integers where the models
now write floats) still reads. A record that is not JSON or not its topic's shape, and a
file that is not MCAP, are one line naming the file, the topic, the time and the field.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.writer import Writer

from schemas import EndReason, ObservationReply
from simhost.host._episode import Observation, Pose
from simhost.host._mcap import McapRecorder
from simhost.host._png import encode_png
from simhost.host._records import (
    AttemptEndEvent,
    CompressedImage,
    EpisodeEndEvent,
    ExceptionArmedEvent,
    ExceptionEvent,
    FrameTransforms,
    FullState,
    McapRecordError,
    OtherEvent,
    OutputFile,
    PosesInFrame,
    RawImage,
    ScenarioRecord,
    SmallTensors,
    StageEndEvent,
    StageStartEvent,
    StateHash,
    StepRequest,
    parse_event,
    read_records,
    read_scenario,
)

SCENARIO = {"episode": "ep1", "track": "sanity", "split": "challenge", "seed": 7,
            "image": "python agent.py", "params": {"start": [0.5, -1.0]},
            "limits": {"cpus": 1.0}, "cpus": None}
REPLY = {"kind": "observation", "seq": 2, "id": None, "stage": "explore", "stage_index": 0,
         "time_left_s": 3.5, "steps_left": None, "observation": {"attempt": 1},
         "action": {"applied": True, "ok": False, "reason": "blocked"},
         "messages": [{"type": "notice", "data": {"text": "hi"}}], "episode_over": False,
         "end_reason": None}


def _recorded(path: Path) -> None:
    r = McapRecorder(path)
    r.write_json("/eagc/scenario", 0.0, SCENARIO)
    r.event(0.0, "stage_start", {"stage": "explore", "index": 0})
    r.request(0.1, "step", "explore", {"action": {"velocity": [0.1, 0.0]}})
    r.state(0.1, 1, "abc", b"\x00\x01")
    r.poses(0.1, 1, {"robot": Pose((1.0, 2.0, 0.0)), "target": Pose((3.0, 4.0, 0.0))})
    tensors = {"rgb": np.full((4, 5, 3), 9, np.uint8), "depth": np.full((4, 5), 2.5, np.float32),
               "segmentation": np.arange(20, dtype=np.int32).reshape(4, 5),
               "proprio": np.array([0.25, 0.5, 0.75, 1.0])}
    r.reply(0.1, REPLY, Observation(data={"attempt": 1}, tensors=tensors))
    r.event(0.2, "exception_armed", {"type": "door_lock", "door": 3, "route_doors": [2, 3]})
    r.event(0.2, "exception", {"type": "door_lock", "goal": 0, "subject": 3, "step": 1,
                               "pose": [1.0, 2.0], "details": {"door": 3},
                               "effect_step": None})
    r.event(0.2, "attempt_end", {"index": 1, "steps": 4, "success": True, "wall_s": 0.5})
    r.event(0.3, "subgoal", {"goal": 0, "subgoal": "picked", "step": 1})
    r.event(0.3, "stage_end", {"stage": "explore", "ended_by": "agent"})
    r.event(0.3, "episode_end", {"reason": EndReason.COMPLETED})
    r.write_raw("/eagc/file/explore/world_model.json", 0.3, b"{}")
    r.close()


def test_every_record_the_recorder_writes_reads_back_typed(tmp_path: Path) -> None:
    path = tmp_path / "episode.mcap"
    _recorded(path)
    records = list(read_records(path))
    by_topic: dict[str, list[Any]] = {}
    for r in records:
        by_topic.setdefault(r.topic, []).append(r.body)

    (scenario,) = by_topic["/eagc/scenario"]
    assert isinstance(scenario, ScenarioRecord)
    assert (scenario.track, scenario.seed, scenario.params) == ("sanity", 7, SCENARIO["params"])
    assert read_scenario(path) == scenario

    (step,) = by_topic["/eagc/request"]
    assert isinstance(step, StepRequest) and step.action == {"velocity": [0.1, 0.0]}
    assert step.stage == "explore"
    (reply,) = by_topic["/eagc/reply"]
    assert isinstance(reply, ObservationReply)
    assert reply.action is not None and reply.action.reason == "blocked"
    assert reply.messages[0].data == {"text": "hi"}
    (small,) = by_topic["/eagc/observation"]
    assert isinstance(small, SmallTensors) and small.vector("proprio") == [0.25, 0.5, 0.75, 1.0]
    assert small.vector("missing") is None
    assert by_topic["/eagc/state_hash"] == [StateHash(step=1, hash="abc")]
    assert by_topic["/eagc/state"] == [FullState(b"\x00\x01")]
    assert by_topic["/eagc/file/explore/world_model.json"] == [
        OutputFile("explore", "world_model.json", b"{}")]

    (tf,) = by_topic["/tf"]
    assert isinstance(tf, FrameTransforms)
    robot = tf.of("robot")
    assert robot is not None and (robot.translation.x, robot.translation.y) == (1.0, 2.0)
    assert tf.of("nobody") is None
    (trajectory,) = by_topic["/trajectory/robot"]
    assert isinstance(trajectory, PosesInFrame) and trajectory.poses[0].position.y == 2.0
    (rgb,) = by_topic["/camera/rgb"]
    assert isinstance(rgb, CompressedImage)
    assert rgb.image_bytes() == encode_png(np.full((4, 5, 3), 9, np.uint8), level=1)
    (depth,) = by_topic["/camera/depth"]
    assert isinstance(depth, RawImage)
    metres = depth.metres()
    assert metres is not None and metres.shape == (4, 5) and float(metres[1, 1]) == 2.5
    assert isinstance(by_topic["/camera/segmentation"][0], CompressedImage)

    events = by_topic["/eagc/event"]
    assert [type(e) for e in events] == [StageStartEvent, ExceptionArmedEvent, ExceptionEvent,
                                         AttemptEndEvent, OtherEvent, StageEndEvent,
                                         EpisodeEndEvent]
    armed, applied, attempt, other = events[1:5]
    assert armed.armed_on == 3 and applied.pose == (1.0, 2.0) and applied.at_step == 1
    assert attempt.success and attempt.index == 1
    assert other.event == "subgoal" and other.at_step == 1
    # Fields as written, in the order written, extras included.
    assert list(applied.fields()) == ["type", "goal", "subject", "step", "pose", "details",
                                      "effect_step"]
    assert attempt.fields() == {"index": 1, "steps": 4, "success": True, "wall_s": 0.5}
    assert other.fields() == {"goal": 0, "subgoal": "picked", "step": 1}
    assert events[-1].reason is EndReason.COMPLETED


def _hand_written(path: Path, messages: list[tuple[str, bytes]]) -> None:
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema("eagc.json", "jsonschema", b'{"type": "object"}')
        channels: dict[str, int] = {}
        for k, (topic, data) in enumerate(messages):
            if topic not in channels:
                channels[topic] = w.register_channel(topic, "json", schema)
            w.add_message(channels[topic], 1_000_000_000 * (k + 1), data, 0)
        w.finish()


def test_a_log_in_the_earlier_json_still_reads(tmp_path: Path) -> None:
    """Integers where the models write floats, and the old writer's spacing."""
    path = tmp_path / "old.mcap"
    pose = {"position": {"x": 1, "y": 2, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0,
                                                                   "w": 1}}
    _hand_written(path, [
        ("/eagc/scenario", json.dumps(SCENARIO).encode()),
        ("/eagc/event", b'{"event": "exception", "type": "target_moved", "step": 4, '
                        b'"at": [1, 2], "to": [0.5, 0.5]}'),
        ("/tf", json.dumps({"transforms": [{
            "timestamp": {"sec": 1, "nsec": 0}, "parent_frame_id": "world",
            "child_frame_id": "robot", "translation": pose["position"],
            "rotation": pose["orientation"]}]}).encode()),
        ("/trajectory/robot", json.dumps({"timestamp": {"sec": 1, "nsec": 0},
                                          "frame_id": "world", "poses": [pose]}).encode()),
        ("/some/foreign/topic", b"\x00 not json"),
    ])
    bodies = [r.body for r in read_records(path)]
    assert [type(b) for b in bodies] == [ScenarioRecord, ExceptionEvent, FrameTransforms,
                                         PosesInFrame]  # the foreign topic is skipped
    moved = bodies[1]
    assert isinstance(moved, ExceptionEvent) and moved.at == [1.0, 2.0] and moved.step == 4


@pytest.mark.parametrize(("topic", "data", "said"), [
    ("/eagc/event", b'{"event": "stage_start", "index": 0}',
     "the /eagc/event record at 1.000 s is not one of eagc's: stage_start.stage: Field "
     "required"),
    ("/eagc/reply", b"{not json", "the /eagc/reply record at 1.000 s is not one of eagc's: "
                                  "not JSON"),
    ("/eagc/request", b'{"kind": "teleport", "stage": "explore"}',
     "the /eagc/request record at 1.000 s is not one of eagc's: Input tag 'teleport'"),
    ("/eagc/state_hash", b'{"step": "many", "hash": 3}',
     "the /eagc/state_hash record at 1.000 s is not one of eagc's: step: Input should be a "
     "valid integer, unable to parse string as an integer (and 1 more)"),
])
def test_a_record_that_is_not_ours_is_one_line(tmp_path: Path, topic: str, data: bytes,
                                               said: str) -> None:
    path = tmp_path / "bad.mcap"
    _hand_written(path, [("/eagc/scenario", json.dumps(SCENARIO).encode()), (topic, data),
                         ("/eagc/state_hash", b'{"step": 1, "hash": "h"}')])
    with pytest.raises(McapRecordError) as caught:
        list(read_records(path))
    text = str(caught.value)
    assert "\n" not in text and text.startswith(f"{path}: ") and said in text, text
    assert isinstance(caught.value, ValueError)  # the picture command's one-line path

    problems: list[McapRecordError] = []
    kept = list(read_records(path, on_problem=problems.append))
    assert [str(p) for p in problems] == [text]
    assert [r.topic for r in kept] == ["/eagc/scenario", "/eagc/state_hash"]


def test_a_file_that_is_not_mcap_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "episode.mcap"
    path.write_bytes(b"this is not an MCAP file at all, just some text\n" * 4)
    with pytest.raises(McapRecordError) as caught:
        list(read_records(path))
    assert "\n" not in str(caught.value) and "not a readable MCAP log" in str(caught.value)
    cut = tmp_path / "cut.mcap"
    _recorded(tmp_path / "whole.mcap")
    cut.write_bytes((tmp_path / "whole.mcap").read_bytes()[:300])  # killed while writing
    problems: list[McapRecordError] = []
    list(read_records(cut, on_problem=problems.append))
    assert len(problems) == 1 and "\n" not in str(problems[0])


def test_an_unknown_event_is_kept_and_a_known_one_must_have_its_fields() -> None:
    other = parse_event({"event": "dance", "step": "twice", "style": "waltz"})
    assert isinstance(other, OtherEvent) and other.at_step is None
    assert other.fields() == {"step": "twice", "style": "waltz"}
    assert isinstance(parse_event({"event": "stage_end", "stage": "a", "ended_by": "agent"}),
                      StageEndEvent)
    with pytest.raises(ValueError, match="ended_by"):
        parse_event({"event": "stage_end", "stage": "a", "ended_by": "magic"})
