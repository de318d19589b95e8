"""Safe collection of /output: regular files only, nothing followed, sizes capped."""

from __future__ import annotations

import os
from pathlib import Path

from orchestrator._episode.collect import collect


def test_regular_files_are_read(tmp_path: Path) -> None:
    (tmp_path / "world_model.json").write_text("{}")
    (tmp_path / ".world_model.json.tmp").write_text("half a file")
    got = collect(tmp_path, max_file_bytes=100, max_total_bytes=1000)
    assert got.files == {"world_model.json": b"{}"}
    assert got.refused == []


def test_links_fifos_folders_and_big_files_are_refused(tmp_path: Path) -> None:
    secret = tmp_path.parent / "secret.txt"
    secret.write_text("hidden seed")
    (tmp_path / "link.json").symlink_to(secret)
    os.mkfifo(tmp_path / "pipe.json")  # opening it for reading would block: never opened
    (tmp_path / "sub").mkdir()
    (tmp_path / "big.bin").write_bytes(b"x" * 101)
    (tmp_path / "bad name.json").write_text("{}")
    got = collect(tmp_path, max_file_bytes=100, max_total_bytes=1000)
    assert got.files == {}
    reasons = {c.name: c.reason for c in got.refused}
    assert "symbolic link" in reasons["link.json"]
    assert "FIFO" in reasons["pipe.json"]
    assert "folder" in reasons["sub"]
    assert "exceeds the cap of 100 bytes" in reasons["big.bin"]
    assert "not a plain file name" in reasons["'bad name.json'"]
    assert all(not c.ok for c in got.refused)


def test_total_cap(tmp_path: Path) -> None:
    for i in range(5):
        (tmp_path / f"f{i}.json").write_bytes(b"x" * 60)
    got = collect(tmp_path, max_file_bytes=100, max_total_bytes=150)
    assert len(got.files) == 2
    assert sum("together exceed" in c.reason for c in got.refused) == 3


def test_missing_folder_is_reported(tmp_path: Path) -> None:
    got = collect(tmp_path / "nope", max_file_bytes=100, max_total_bytes=100)
    assert got.files == {} and "cannot open" in got.refused[0].reason
