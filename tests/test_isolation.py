"""The suite does not depend on the machine being empty (issue 10 §6).

Another eagc run on the machine holds CPU locks in the default lock folder (/tmp): a test
session uses its own, so an episode of a test is never left without a placement by it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator._runtimes.cpus import _lock_dir, placed


def test_the_session_has_its_own_lock_folder(tmp_path_factory: pytest.TempPathFactory) -> None:
    folder = Path(os.environ["EAGC_LOCK_DIR"])
    assert folder.is_dir()
    assert folder.is_relative_to(tmp_path_factory.getbasetemp())
    assert _lock_dir() == folder != Path("/tmp")


def test_processes_started_by_tests_inherit_it() -> None:
    """Drivers and Ray workers are processes the tests start: they see the same folder."""
    r = subprocess.run([sys.executable, "-c",
                        "from orchestrator._runtimes.cpus import _lock_dir; print(_lock_dir())"],
                       capture_output=True, text=True, check=True)
    assert r.stdout.strip() == os.environ["EAGC_LOCK_DIR"]


def test_a_placement_is_claimed_in_the_sessions_folder() -> None:
    with placed(1.0) as placement:  # a host core and an agent core: CI has two or more
        assert placement is not None
        locks = sorted(p.name for p in Path(os.environ["EAGC_LOCK_DIR"]).iterdir())
        assert f"eagc-cpu-{placement.host[0]}.lock" in locks
