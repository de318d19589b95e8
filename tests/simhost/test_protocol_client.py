"""The client written from schemas/PROTOCOL.md alone plays a sanity episode to completion.

``examples/protocol_client/agent.py`` imports no eagc module (zenoh, numpy and the standard
library only). It runs as the agent of a real episode (real host, real Zenoh, real MuJoCo,
the worker's own collection and scoring), with every eagc package and pydantic made
unimportable in its process, so that the page, not the code beside it, is what it relies on.
"""

from __future__ import annotations

import ast
import sys
import tempfile
import textwrap
from pathlib import Path

from orchestrator._episode.worker import EpisodeSpec, run_episode
from orchestrator._runtimes.local import LocalProcessRuntime
from schemas import EpisodeStatus

CLIENT = Path(__file__).resolve().parents[2] / "examples" / "protocol_client" / "agent.py"
ALLOWED = {"__future__", "json", "os", "struct", "sys", "time", "typing", "numpy", "zenoh"}
FORBIDDEN = ("schemas", "simhost", "plugins", "orchestrator", "pydantic", "pydantic_core")

# Runs the client with eagc and pydantic unimportable: an import of them fails at once.
_GUARD = textwrap.dedent(
    f"""
    import importlib.abc, runpy, sys

    class Forbid(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name.split(".")[0] in {FORBIDDEN!r}:
                raise ImportError(f"the protocol client may not import {{name}}")
            return None

    sys.meta_path.insert(0, Forbid())
    sys.argv = sys.argv[1:]
    runpy.run_path(sys.argv[0], run_name="__main__")
    """
)


def test_the_client_imports_only_zenoh_numpy_and_the_standard_library():
    tree = ast.parse(CLIENT.read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0])
    assert imported <= ALLOWED, sorted(imported - ALLOWED)


def test_the_client_plays_a_sanity_episode_to_completion(tmp_path):
    guard = tmp_path / "guard.py"
    guard.write_text(_GUARD)
    runs = Path(tempfile.mkdtemp(prefix="eagc-", dir="/tmp"))  # short: socket path limit
    result = run_episode(
        EpisodeSpec(track="sanity", image=f"{sys.executable} {guard} {CLIENT}", seed=11,
                    split="challenge", runs_dir=runs),  # challenge: the exception happens
        LocalProcessRuntime(quiet=True),
    )
    tail = result.container.log_tail if result.container else ""
    assert result.status is EpisodeStatus.COMPLETED, (result.failure, tail)
    assert "episode over: completed" in tail
    assert result.stats.protocol_errors == {} and result.stats.invalid_actions == 0
    assert result.stages_reached == ("explore", "reach")
    assert {f.name: f.ok for f in result.files} == {"world_model.json": True,
                                                    "episode_log.jsonl": True}
    # The exception happened and the client noticed it (the score's recovery part).
    assert result.score.components.get("recovery", 0.0) > 0.5, result.score
    assert result.score.total > 0.6
