"""The simulators' typed step info (``HouseInfo``, ``BenchInfo``) and gymnasium's plain
``info`` dict made from it at the edge: the same report, key for key."""

from __future__ import annotations

import numpy as np

from simhost.worlds.track1 import HouseEnv, HouseInfo, make_action
from simhost.worlds.track2 import BenchEnv, BenchInfo

HOUSE_KEYS = {"action_result", "collided", "detections", "room", "held", "step",
              "sim_warnings"}
BENCH_KEYS = {"progress", "success", "stage", "value", "contact_force", "push_force",
              "sim_warnings", "events", "invalid_action", "action_clipped", "joint_limit",
              "step"}


def test_the_house_reports_the_same_typed_and_as_gymnasium_dict() -> None:
    plain, typed = HouseEnv(split="standard"), HouseEnv(split="standard")
    try:
        obs_a, info_a = plain.reset(seed=5)
        obs_b, info_b = typed.reset_typed(seed=5)
        assert isinstance(info_a, dict) and isinstance(info_b, HouseInfo)
        assert set(info_a) == HOUSE_KEYS and info_b.as_dict() == info_a
        actions = [make_action("move", forward=1.0), make_action("move", turn=0.5),
                   make_action("open", target=3), make_action("pick", target=999)]
        for action in actions:
            *out_a, info_a = plain.step(action)
            *out_b, info_b = typed.step_typed(action)
            assert isinstance(info_a, dict) and info_b.as_dict() == info_a
            assert all(np.array_equal(out_a[0][k], out_b[0][k]) for k in out_a[0])
            assert out_a[1:] == out_b[1:]
            assert info_b.collided == info_a["collided"]
            assert [d.id for d in info_b.detections] == [d["id"] for d in info_a["detections"]]
            assert info_b.room_type == info_a["room"]["type"]
        assert not info_b.action_result.ok and info_a["action_result"]["reason"]
        assert set(info_a["action_result"]) == {"ok", "reason", "primitive"}
        assert set(info_a["room"]) == {"id", "type"}
        assert set(info_a["detections"][0]) == {"id", "kind", "category", "colour", "rel_pos",
                                                "state"} if info_a["detections"] else True
        assert plain.observe()[1] == typed.observe_typed()[1].as_dict()
    finally:
        plain.close()
        typed.close()


def test_the_bench_reports_the_same_typed_and_as_gymnasium_dict() -> None:
    plain, typed = BenchEnv(family="opening"), BenchEnv(family="opening")
    try:
        _, info_a = plain.reset(seed=3)
        _, info_b = typed.reset_typed(seed=3)
        assert isinstance(info_b, BenchInfo) and set(info_a) == BENCH_KEYS
        assert info_b.as_dict() == info_a
        rng = np.random.default_rng(0)
        for _ in range(25):
            action = rng.uniform(-1, 1, 5).astype(np.float32)
            *out_a, info_a = plain.step(action)
            *out_b, info_b = typed.step_typed(action)
            assert info_b.as_dict() == info_a and out_a[1:] == out_b[1:]
            assert info_b.drops == sum(e["event"] == "dropped" for e in info_a["events"])
        bad = np.full(5, np.nan, np.float32)
        assert typed.step_typed(bad)[4].invalid_action and plain.step(bad)[4]["invalid_action"]
    finally:
        plain.close()
        typed.close()
