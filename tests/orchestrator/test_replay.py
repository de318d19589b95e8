"""``eagc replay --verify``: re-simulating an episode reproduces its log bit for bit."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import Writer

from orchestrator._episode.replay import replay
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus
from simhost.host._host import HostConfig

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"


def _episode(seed: int) -> Path:
    runs = Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))
    result = run_episode(
        EpisodeSpec(track="sanity", image=f"python {AGENT}", seed=seed, split="challenge",
                    runs_dir=runs),
        LocalProcessRuntime(quiet=True),
    )
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    assert result.mcap is not None
    return Path(result.mcap)


def test_replay_matches_the_live_run() -> None:
    mcap = _episode(seed=21)
    report = replay(mcap)
    assert report.ok, report.mismatches
    assert report.steps > 20 and report.hashes_checked == report.steps
    assert report.states_checked == report.steps // HostConfig.full_state_every


def test_a_tampered_log_is_caught(tmp_path: Path) -> None:
    mcap = _episode(seed=22)
    tampered = tmp_path / "tampered.mcap"
    with mcap.open("rb") as src, tampered.open("wb") as dst:
        reader = make_reader(src)
        writer = Writer(dst)
        writer.start()
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        flipped = False
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding,
                    schemas.get(channel.schema_id, 0))
            data = message.data
            if channel.topic == "/eagc/request":
                doc = json.loads(data)
                if doc["kind"] == "step" and not flipped:  # the first step goes the other way
                    doc["action"]["velocity"] = [-v for v in doc["action"]["velocity"]]
                    flipped = True
                    data = json.dumps(doc).encode()
            writer.add_message(channels[channel.id], message.log_time, data,
                               message.publish_time)
        writer.finish()
    report = replay(tampered)
    assert not report.ok
    assert report.mismatches[0].startswith("step 1: state hash")
