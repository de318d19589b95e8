"""Gymnasium's convention: ``import simhost`` registers every eagc environment, MuJoCo loads
only when one is made, ``gymnasium.make("simhost:<id>")`` works in a fresh process, and
every registered environment passes gymnasium's own ``check_env``.

The tests are parametrized over what ``import simhost`` registers, so an id a track adds
to its ``_register.py`` is covered without touching this file.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import simhost

ROOT = Path(__file__).parents[2]
IDS = simhost.env_ids()


def _run(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout.splitlines()[-1]


@pytest.mark.parametrize("order", ["simhost first", "gymnasium first"])
def test_import_simhost_registers_every_track_without_mujoco(order):
    first, second = ("simhost", "gymnasium") if order == "simhost first" else (
        "gymnasium", "simhost")
    report = json.loads(_run(
        f"import json, sys\nimport {first}\nimport {second}\n"
        "from gymnasium.envs.registration import registry\n"
        "ids = sorted(i for i, s in registry.items() if str(s.entry_point).startswith('simhost.'))"
        "\nprint(json.dumps({'ids': ids, 'mujoco': 'mujoco' in sys.modules}))"
    ))
    assert not report["mujoco"], "registering must not import MuJoCo"
    assert report["ids"] == IDS
    tracks = {p.parent.name for p in (ROOT / "simhost" / "worlds").glob("*/_register.py")}
    assert tracks >= {"sanity", "track1"}
    for track in tracks:  # every track that has a _register.py registered something
        registered = [i for i in IDS
                      if gym.spec(i).entry_point.startswith(f"simhost.worlds.{track}.")]
        assert registered, f"simhost/worlds/{track}/_register.py registered no id"
    assert {"eagc/Sanity-v0", "eagc/House-v0"} <= set(IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_make_works_in_a_fresh_process(env_id):
    report = json.loads(_run(
        "import json, gymnasium as gym\n"
        f"env = gym.make('simhost:{env_id}')\n"
        "obs, info = env.reset(seed=3)\n"
        "ok = env.observation_space.contains(obs)\n"
        "env.close()\n"
        "print(json.dumps({'contains': bool(ok)}))"
    ))
    assert report["contains"]


@pytest.mark.parametrize("env_id", IDS)
def test_check_env(env_id):
    env = gym.make(env_id)
    try:
        check_env(env.unwrapped, skip_render_check=True)
    finally:
        env.close()
