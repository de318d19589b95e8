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
