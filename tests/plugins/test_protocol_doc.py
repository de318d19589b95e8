"""schemas/PROTOCOL.md never drifts from the code, like schemas/json/.

Its generated sections (message fields, error codes, end reasons, the byte example, and
each track's stages, observation and action specs and files) must equal what
``python -m plugins.protocol_doc`` renders from the code now.
"""

from __future__ import annotations

import re
from typing import get_args

import pytest

from plugins import protocol_doc
from plugins._registry import available_tracks
from schemas import _protocol as proto

FIX = "regenerate it with `python -m plugins.protocol_doc` (never edit those sections by hand)"


@pytest.mark.slow
def test_protocol_page_matches_the_code():
    assert not protocol_doc.stale(), f"{protocol_doc.DOC} is stale: {FIX}"


def test_every_installed_track_has_its_section():
    text = protocol_doc.DOC.read_text()
    for track in available_tracks():
        assert f"<!-- generated:track:{track} " in text, f"no section for {track!r}: {FIX}"


def test_a_changed_spec_makes_the_page_stale(tmp_path):
    page = tmp_path / "PROTOCOL.md"
    text = protocol_doc.DOC.read_text()
    row = "| `velocity` | float32 | [2] | -1 … 1 |"
    assert row in text
    page.write_text(text.replace(row, "| `velocity` | float32 | [3] | -1 … 1 |", 1))
    assert protocol_doc.stale(page) == ["track:sanity"]


def test_a_new_track_gets_a_section(tmp_path):
    text = protocol_doc.DOC.read_text()
    start = text.index("### Track `sanity`")
    end = text.index("<!-- end generated:track:sanity -->") + len(
        "<!-- end generated:track:sanity -->")
    without = text[:start] + text[end:]
    again = protocol_doc.render(without, tracks=["sanity"])
    assert "### Track `sanity`" in again
    assert "| `target_visible` | float32 | [1] |" in again
    assert again.index("### Track `sanity`") < again.index("<!-- end tracks -->")


def test_error_codes_and_end_reasons_are_all_explained():
    assert set(proto.ERROR_CODES) == set(get_args(proto.ErrorCode))
    assert all(text for text in proto.ERROR_CODES.values())
    assert all(r.description for r in proto.EndReason)
    text = protocol_doc.DOC.read_text()
    for code in proto.ERROR_CODES:
        assert f"| `{code}` |" in text


def test_the_byte_example_decodes_to_what_it_says():
    """The example is the encoder's own output; the decoder reads it back."""
    from simhost._wire import decode_request

    text = protocol_doc.example_section()
    hexes = re.findall(r"^\d+\s+((?:[0-9a-f]{2} )+[0-9a-f]{2})", text, re.M)
    header = re.search(r"^        (\{.*\})$", text, re.M)
    assert header is not None and len(hexes) == 4
    h = int.from_bytes(bytes.fromhex(hexes[1]), "little")
    raw = header.group(1).encode()
    buf = bytes.fromhex(hexes[0]) + bytes.fromhex(hexes[1]) + raw + b" " * (h - len(raw))
    buf += bytes.fromhex(hexes[2]) + bytes.fromhex(hexes[3])
    msg, tensors = decode_request(buf)
    assert (msg.kind, msg.seq, msg.id) == ("step", 3, 7)
    assert tensors["velocity"].tolist() == [0.5, -0.25]
    assert tensors["mask"].tolist() == [1, 0, 1]


@pytest.mark.parametrize("target", sorted(set(re.findall(
    r"\]\(((?:\.\./|json/)[^)#]+)\)", protocol_doc.DOC.read_text()))))
def test_links_on_the_page_exist(target):
    assert (protocol_doc.DOC.parent / target).resolve().exists(), target


@pytest.mark.slow
def test_the_contract_page_matches_the_code():
    page = protocol_doc.PAGES[1]
    assert page.name == "contract.md"
    assert not protocol_doc.stale(page), f"{page} is stale: {FIX}"


def test_every_page_holds_the_vocabulary_sections():
    """The issue's list (issue 22 §6): the environment, log step numbering and the client's
    types are generated into the pages; the tracks' vocabulary into their sections."""
    protocol, contract = (p.read_text() for p in protocol_doc.PAGES[:2])
    for name in ("environment", "log-steps"):
        assert f"<!-- generated:{name} " in protocol, name
    for name in ("environment", "client"):
        assert f"<!-- generated:{name} " in contract, name
    for words in ("Failure reasons an action result may carry", "Reach (the robot's centre",
                  "The graded inventory", "Planning messages", "`steps`:"):
        assert words in protocol, words
    for words in ("trajectory.npz", "Task-model names per family",
                  "How a model is compared with the truth"):
        assert words in protocol, words


def test_the_environment_table_is_every_variable_a_container_gets():
    from schemas import CONTAINER

    env = CONTAINER.environment("ep", socket_dir="/s", output_dir="/o", input_dir="/i")
    table = protocol_doc.environment_section()
    names = re.findall(r"^\| `(\w+)` \|", table, re.M)
    assert names == [v.name for v in CONTAINER.variables()]
    assert set(names) == set(env)
    assert f"| `{CONTAINER.env_output}` | `{CONTAINER.output_dir}` |" in table
    for page in protocol_doc.PAGES[:2]:  # the pages carry today's table
        assert table.strip() in page.read_text(), page


def test_a_changed_variable_makes_both_pages_stale(monkeypatch):
    import dataclasses

    from schemas import CONTAINER

    monkeypatch.setattr(protocol_doc.schemas, "CONTAINER",
                        dataclasses.replace(CONTAINER, env_output="EAGC_OUT"))
    for page in protocol_doc.PAGES[:2]:  # the tracks' sections left as they are: fast
        text = page.read_text()
        fresh = protocol_doc.render(text, tracks=[], add_tracks=False)
        assert fresh != text and "| `EAGC_OUT` | `/output` |" in fresh, page


def test_the_client_section_names_every_timestep_field():
    from simhost.client import OutputFiles, RemoteEnv, TimeStep

    text = protocol_doc.client_section()
    for name in TimeStep._fields:
        assert f"| `{name}` |" in text, name
    for fn in (RemoteEnv.step, RemoteEnv.end_stage, RemoteEnv.answer, OutputFiles.write,
               OutputFiles.log):
        assert f"`{fn.__name__}(" in text
    assert "step(action) → TimeStep" in text
    assert text.strip() in protocol_doc.PAGES[1].read_text()


def test_only_served_step_requests_are_counted(host_episode):
    """What the log-steps section says (``COUNTED``), played through a real host: hello,
    reset, end_stage and a step refused with an error reply leave the count alone."""
    from simhost.client import HostError, RemoteEnv

    assert protocol_doc.COUNTED == ("step",)
    assert "`end_stage` requests" in protocol_doc.log_steps_section()
    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=10.0)
    try:
        env.hello(agent="count/1")
        env.reset()
        env.step({"velocity": [0.5, 0.0]})
        env.step({"velocity": [0.0, 0.5]})
        ts = env.end_stage({})
        assert ts.stage_index == 1
        with pytest.raises(HostError):
            env.step({"velocity": [float("nan"), 0.0]})
        env.step({"velocity": [0.0, 0.0]})
    finally:
        env.close()
    host_episode.stop.set()
    assert host_episode.outcome().steps == 3


def test_the_pages_answer_a_new_team_s_questions():
    """Issue 35 §4: the facts a team writing from the docs alone had to find by trying."""
    protocol, contract, commands = (p.read_text() for p in protocol_doc.PAGES)
    from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS

    for true, alikes in (*CONFUSABLE.items(), *CONFUSABLE_COLOURS.items()):
        assert f"| `{true}` | " + ", ".join(f"`{a}`" for a in alikes) + " |" in protocol
    for words in ("`ts.observation[\"action_result\"]`", "`env.answer({", "`answer_with`",
                  "none is graded", "Which split an episode plays is never sent",
                  "Part names:", "Constraint values"):
        assert words in protocol, words
    assert "| `max_steps` | integer \\| null |" in contract  # StageInfo, for env.stages[i]
    assert "a list of StageInfo" in contract
    assert "<!-- generated:episode-result " in commands
    assert "| `status` | \"completed\" \\|" in commands


def test_the_answer_table_is_what_the_grader_gives():
    from plugins.track1 import _queries
    from plugins.track1._vocabulary import answer_lines

    text = "\n".join(answer_lines([{"id": "q0", "kind": "tools_for"}], "say it"))
    assert '`env.answer({"q0": [41, 57]})`' in text
    f1 = _queries.score_answer("tools_for", [41], [41, 57])
    assert f"| `tools_for` | list of ids | `[41, 57]` | `[41, 57]` | 1.00 | `[41]` | {f1:.2f} |" \
        in text


def test_split_signs_name_what_only_some_splits_have():
    lines = protocol_doc.split_signs({"standard": {"a", "rgb"}, "challenge": {"a", "rgb"},
                                      "dev": {"a", "goal"}})
    assert "`rgb` only on `standard`, `challenge`" in lines[0]
    assert "`goal` only on `dev`" in lines[0]
    assert protocol_doc.split_signs({"standard": {"a"}, "dev": {"a"}}) == []


def test_every_numeric_track2_constraint_has_a_unit():
    from plugins.track2._vocabulary import UNITS, variants
    from simhost.worlds.track2 import FAMILIES, split_config, task_truth

    config = split_config("standard").bench
    for family in FAMILIES:
        for params in variants(family):
            for c in task_truth(params, config).constraints:
                numeric = not isinstance(c.value, bool | str) and not (
                    isinstance(c.value, list) and all(isinstance(v, str) for v in c.value))
                if numeric:
                    assert c.name in UNITS, (family, c.name)


@pytest.mark.slow
def test_every_annotated_part_of_a_demonstration_has_its_row(tmp_path):
    """The part-name table covers the names a real packet's annotations use."""
    import json

    from plugins._registry import load_track
    from plugins.track2._vocabulary import part_rows

    order, found = part_rows()
    assert found["opening"]["drawer"] == {"mover"}
    assert found["tool_use"]["button"] == {"target"}
    plugin = load_track("track2")
    for i in range(5):
        scenario = plugin.make_scenario(seed=i, split="standard",
                                        params={"demo_frames": False}, index=i)
        out = tmp_path / str(i)
        plugin.write_inputs(scenario, out)
        manifest = json.loads(next(out.rglob("manifest.json")).read_text())
        family = manifest["family"]
        assert manifest["observation_spec"]["parts"]["rows"] == list(order[family])
        for event in manifest["events"]:
            assert found[family].get(event["part"]), (family, event)
