"""``attempt_png``: an attempt of a recorded episode drawn beside the demonstration.

Reads the episode's MCAP log (``host/episode.mcap``): ``/eagc/scenario`` for the source and
demonstration seed, ``/eagc/reply`` for the stage and attempt of every reply, and the
``/eagc/observation`` that follows each reply for the hand's position. The demonstration
comes from the episode's ``input/demo`` folder, or is written again from the scenario (the
same source and seed give the same packet) when that folder is gone.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from plugins.track2._episode import DEMO_FOLDER, EXECUTION
from plugins.track2._scenario import Track2Scenario


def _read_log(mcap: Path) -> tuple[dict[str, Any], dict[int, list[list[float]]], int | None]:
    """The scenario, the hand's path per attempt and the attempt that succeeded."""
    from mcap.reader import make_reader

    scenario: dict[str, Any] = {}
    won: int | None = None
    paths: dict[int, list[list[float]]] = {}
    current: int | None = None
    with mcap.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            topic = channel.topic
            if topic == "/eagc/scenario":
                scenario = json.loads(message.data)
            elif topic == "/eagc/reply":
                reply = json.loads(message.data)
                current = None
                if reply.get("kind") == "observation" and reply.get("stage") == EXECUTION:
                    current = int((reply.get("observation") or {}).get("attempt") or 0) or None
            elif topic == "/eagc/event":
                ev = json.loads(message.data)
                if ev.get("event") == "attempt_end" and ev.get("success"):
                    won = int(ev["index"])
            elif topic == "/eagc/observation" and current is not None:
                proprio = json.loads(message.data).get("proprio")
                if proprio:
                    paths.setdefault(current, []).append([float(x) for x in proprio[:3]])
    return scenario, paths, won


def attempt_png(
    episode_dir: str | Path, *, attempt: int | None = None, path: str | Path | None = None
) -> Path:
    """Draw one attempt of a Track 2 episode against its demonstration; return the PNG's path.

    Args:
      episode_dir: the episode's folder (``<runs>/<episode>``, holding ``host/episode.mcap``).
      attempt: which attempt (1-based); default the successful one, else the last.
      path: where to write; default ``<episode_dir>/host/attempt_<k>.png``.

    Raises:
      FileNotFoundError: no MCAP log in the folder.
      ValueError: not a Track 2 episode, or the attempt has no recorded step.
    """
    from simhost.track2 import render_attempt_vs_demo, write_demo_packet

    root = Path(episode_dir)
    mcap = root / "host" / "episode.mcap"
    if not mcap.is_file():
        raise FileNotFoundError(f"{mcap} does not exist: is {root} an episode folder?")
    scenario, paths, won = _read_log(mcap)
    if scenario.get("track") != "track2":
        raise ValueError(f"{root} is a {scenario.get('track')!r} episode, not track2")
    if not paths:
        raise ValueError(f"{root}: the agent never reached the execution stage; nothing to draw")
    k = attempt or won or max(paths)
    if k not in paths:
        raise ValueError(f"{root}: attempt {k} has no recorded step (attempts: {sorted(paths)})")
    out = Path(path) if path is not None else root / "host" / f"attempt_{k}.png"
    demo = root / "input" / DEMO_FOLDER
    attempt_xyz = np.asarray(paths[k])
    if (demo / "manifest.json").is_file():
        render_attempt_vs_demo(demo, attempt_xyz, path=out)
        return out
    hidden = Track2Scenario.model_validate(scenario["params"])
    with tempfile.TemporaryDirectory() as tmp:
        write_demo_packet(Path(tmp) / DEMO_FOLDER, hidden.source, seed=hidden.demo_seed,
                          config=hidden.bench, frames=hidden.demo_frames)
        render_attempt_vs_demo(Path(tmp) / DEMO_FOLDER, attempt_xyz, path=out)
    return out
