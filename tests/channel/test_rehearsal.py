"""The rehearsal of the whole calendar in CI: a real channel, registry and Ray on a
compressed clock; three phases; finalists by rank ranges; a final frozen, signed, verified
(and not verified once a byte of a file it names changes), audited, ruled on, released."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.docker, pytest.mark.slow]


def test_the_rehearsal_plays_the_calendar_end_to_end(images: dict[str, str],
                                                     tmp_path: Path) -> None:
    import subprocess

    out = tmp_path / "rh"
    done = subprocess.run([sys.executable, "-m", "orchestrator.cli", "challenge", "rehearse",
                           "--output", str(out)], capture_output=True, text=True,
                          timeout=1500, cwd=tmp_path)  # from any working directory
    assert done.returncode == 0, (done.stdout, done.stderr[-3000:])
    summary = json.loads((out / "rehearsal.json").read_text())
    assert [r["team"] for r in summary["boards"]["testing"]] == ["team-a"]
    assert {r["team"] for r in summary["boards"]["qual"]} == {"team-a", "team-b", "team-c"}
    # The same agent thrice: the ranges cannot tell them apart, so none is cut by a coin
    # flip at K = 2 (the cap is 2 K).
    assert sorted(summary["finalists"]) == ["team-a", "team-b", "team-c"]
    assert summary["verified"]
    assert {r["team"] for r in summary["boards"]["final"]} == set(summary["finalists"])
    assert "public board:" in done.stdout and "verified" in done.stdout
    assert "team-a froze" in done.stderr  # as a team does, over the API (`eagc freeze`)
    # One changed byte of a file the manifest names: verify fails, naming it.
    manifest = Path(summary["manifest"])
    report = manifest.parent / "team-a" / "report.md"
    report.write_bytes(report.read_bytes().replace(b"The", b"Thd", 1))
    bad = subprocess.run([sys.executable, "-m", "orchestrator.cli", "challenge", "verify",
                          str(manifest)], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 1
    assert "team-a/report.md" in bad.stdout + bad.stderr
