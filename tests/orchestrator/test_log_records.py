"""An episode log with a record that is not ours: every reader says so in one line.

A real sanity episode runs once (the agent as a local process); a copy of its folder gets
a log in which one stage-end event lacks ``ended_by``. The viewer still draws the page and
lists the record among its problems; the audit, the replay and ``eagc picture`` /
``eagc replay`` end in one line that names the record, never a traceback.
"""

from __future__ import annotations

import io
import json
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from typer.testing import CliRunner

from orchestrator._episode.audit import EpisodeAuditError, audit_episode
from orchestrator._episode.replay import ReplayError, replay
from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from orchestrator._viewer.episode import read_episode
from orchestrator.cli.main import app
from schemas import EpisodeStatus, Limits

AGENT = Path(__file__).resolve().parents[2] / "examples" / "sanity_agent" / "agent.py"
SAID = "the /eagc/event record at"


@pytest.fixture(scope="module")
def episode() -> Iterator[Path]:
    runs = Path(tempfile.mkdtemp(prefix="eagc-lr-", dir="/tmp"))  # short: unix sockets
    result = run_episode(EpisodeSpec(
        track="sanity", image=f"{sys.executable} {AGENT}", seed=5, split="challenge",
        runs_dir=runs, limits=Limits(startup_s=60.0, pin_cpus=False)),
        LocalProcessRuntime(quiet=True))
    assert result.status is EpisodeStatus.COMPLETED, result.failure
    yield Path(result.episode_dir or "")
    shutil.rmtree(runs, ignore_errors=True)


@pytest.fixture()
def damaged(episode: Path, tmp_path: Path) -> Path:
    """A copy of the episode whose first stage_end event lacks ``ended_by``."""
    folder = tmp_path / episode.name
    shutil.copytree(episode, folder, ignore=shutil.ignore_patterns("sock"))
    mcap = folder / "host" / "episode.mcap"
    source = (episode / "host" / "episode.mcap").read_bytes()
    broken = False
    with mcap.open("wb") as dst:
        writer = Writer(dst)
        writer.start()
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in make_reader(io.BytesIO(source)).iter_messages(
                log_time_order=True):
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas.get(channel.schema_id, 0))
            data = message.data
            if channel.topic == "/eagc/event" and not broken:
                doc = json.loads(data)
                if doc["event"] == "stage_end":
                    del doc["ended_by"]
                    data, broken = json.dumps(doc).encode(), True
            writer.add_message(channels[channel.id], message.log_time, data,
                               message.publish_time)
        writer.finish()
    assert broken
    return folder


def _one_line(text: str) -> bool:
    return "\n" not in text.strip() and "Traceback" not in text


def test_the_page_lists_the_record_and_shows_the_rest(damaged: Path, episode: Path) -> None:
    whole = read_episode(episode, organizer=True)
    assert not whole.problems
    view = read_episode(damaged, organizer=True)
    problem, picture = view.problems  # the track's picture reads the same log
    assert SAID in problem and "stage_end.ended_by: Field required" in problem
    assert _one_line(problem) and picture == f"no track picture: {problem}"
    # Everything else is read: one stage-end event fewer, the same frames and path.
    assert len(view.events) == len(whole.events) - 1
    assert view.path == whole.path and view.hidden == whole.hidden
    assert [s["name"] for s in view.stages] == [s["name"] for s in whole.stages]


def test_audit_and_replay_refuse_in_one_line(damaged: Path) -> None:
    with pytest.raises(EpisodeAuditError) as audit:
        audit_episode(damaged)
    assert SAID in str(audit.value) and _one_line(str(audit.value))
    with pytest.raises(ReplayError) as replayed:
        replay(damaged / "host" / "episode.mcap")
    assert SAID in str(replayed.value) and _one_line(str(replayed.value))


def test_the_commands_end_in_one_line(damaged: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    picture = runner.invoke(app, ["picture", str(damaged), "--out", str(tmp_path / "p.png")])
    assert picture.exit_code == 2, picture.output
    assert SAID in picture.output and "Traceback" not in picture.output
    replayed = runner.invoke(app, ["replay", str(damaged)])
    assert replayed.exit_code == 1, replayed.output
    assert SAID in replayed.output and "Traceback" not in replayed.output
    report = runner.invoke(app, ["report", str(damaged), "--out", str(tmp_path / "site")])
    assert report.exit_code == 0, report.output
    assert SAID in (tmp_path / "site" / "index.html").read_text()
