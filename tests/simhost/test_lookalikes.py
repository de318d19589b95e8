"""Track 1's look-alike tables are agent-side data: importable without the simulator."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[2]

_PROBE = """
import sys
for name in ("gymnasium", "mujoco"):
    sys.modules[name] = None  # an import of either fails, as in the agent base image
import json
from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS
import simhost.client
loaded = sorted(m for m, v in sys.modules.items() if v is not None)
print(json.dumps({
    "confusable": {k: list(v) for k, v in CONFUSABLE.items()},
    "colours": {k: list(v) for k, v in CONFUSABLE_COLOURS.items()},
    "exported": sorted(set(simhost.client.__all__) & {"CONFUSABLE", "CONFUSABLE_COLOURS"}),
    "worlds": [m for m in loaded if m.startswith("simhost.worlds")],
}))
"""


def _probe() -> dict[str, object]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE], capture_output=True, text=True, check=True, cwd=ROOT
    )
    result: dict[str, object] = json.loads(out.stdout.splitlines()[-1])
    return result


def test_the_tables_import_where_gymnasium_and_mujoco_cannot():
    from simhost.worlds.track1 import CONFUSABLE, CONFUSABLE_COLOURS

    got = _probe()
    assert got["exported"] == ["CONFUSABLE", "CONFUSABLE_COLOURS"]
    assert got["worlds"] == [], "the client must not import a track's world"
    assert got["confusable"] == {k: list(v) for k, v in CONFUSABLE.items()}
    assert got["colours"] == {k: list(v) for k, v in CONFUSABLE_COLOURS.items()}


def test_the_world_uses_the_client_tables_themselves():
    import simhost.client
    from simhost.worlds.track1 import _catalogue, _perception

    assert _catalogue.CONFUSABLE is simhost.client.CONFUSABLE
    assert _perception.CONFUSABLE_COLOURS is simhost.client.CONFUSABLE_COLOURS


def test_every_look_alike_is_a_name_of_the_same_vocabulary():
    from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS
    from simhost.worlds.track1 import (
        COLOURS,
        CONTAINER_CATEGORIES,
        FURNITURE_CATEGORIES,
        OBJECT_CATEGORIES,
        TOOL_CATEGORIES,
    )

    kinds = (FURNITURE_CATEGORIES, CONTAINER_CATEGORIES, OBJECT_CATEGORIES, TOOL_CATEGORIES)
    for true, alikes in CONFUSABLE.items():
        same_kind = next(k for k in kinds if true in k)  # doors are never confused
        assert alikes and set(alikes) <= set(same_kind), true
        assert true not in alikes
    for true, alikes in CONFUSABLE_COLOURS.items():
        assert true in COLOURS and alikes and set(alikes) <= set(COLOURS)
        assert true not in alikes
