"""Track 2's words on the protocol page (``Track2.vocabulary``): the demonstration packet's
arrays, the task-model names per family (from the truths of sampled instances: what
``task_model.json`` is compared with) and how values are compared."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from plugins._base import TrackPlugin
from plugins.track2 import _scoring
from plugins.track2._scenario import Track2Scenario

#: Instances sampled (seeds and indexes 0..SAMPLES-1): one of each family, as the index
#: balances them.
SAMPLES = 5


def vocabulary(plugin: TrackPlugin[Track2Scenario, Any]) -> str:
    """The Markdown that ends Track 2's section of the protocol page."""
    from simhost.worlds.track2 import task_truth

    split = next(iter(plugin.splits))
    truths: dict[str, Any] = {}
    for i in range(SAMPLES):
        s = Track2Scenario.of(plugin.make_scenario(
            seed=i, split=split, params={"demo_frames": False}, index=i))
        truths.setdefault(s.family, task_truth(s.instance, s.bench))
    rows = ["| family | stages | variables | constraints | preconditions | success |",
            "|---|---|---|---|---|---|"]
    for family, t in sorted(truths.items()):
        pre = "; ".join(f"`{k}`: " + ", ".join(f"`{r}`" for r in v)
                        for k, v in t.preconditions.items())
        rows.append(
            f"| `{family}` | " + " ".join(f"`{x}`" for x in t.stages) + " | "
            + ", ".join(f"`{v.name}`" for v in t.state_variables) + " | "
            + ", ".join(f"`{c.name}`" for c in t.constraints) + f" | {pre or '—'} | "
            + ", ".join(f"`{c.variable} {c.op}`" for c in t.success) + " |")
    examples = [(0.0105, 0.01), (0.011, 0.01), (0.012, 0.01), (1.1, 1.0), ([1.0, 2.2],
                [1.0, 2.0]), (True, True), ("Peg", "peg")]
    cases = "; ".join(f"`{json.dumps(p)}` for `{json.dumps(t)}`: {_scoring.close(p, t):.2f}"
                      for p, t in examples)
    rule = next(" ".join(b.split()) for b in (_scoring.__doc__ or "").split("\n- ")
                if b.startswith("``task_model``"))
    weights = ", ".join(f"{k} {w:g}" for k, w in _scoring.MODEL_WEIGHTS.items())
    return "\n".join([
        *packet_keys(plugin, split),
        f"Task-model names per family (the truths of sampled `{split}` instances; "
        "`simhost.worlds.track2.task_truth`): a model of another family scores 0.",
        "",
        *rows,
        "",
        "How a model is compared with the truth (`plugins.track2._scoring`, weights "
        f"`MODEL_WEIGHTS`: {weights}): {rule.removeprefix('``task_model``: ')}",
        "",
        "Values (constraints, success criteria) are compared by "
        "`plugins.track2._scoring.close`, credit in [0, 1]; for example " + cases + ".",
    ])


def packet_keys(plugin: TrackPlugin[Track2Scenario, Any], split: str) -> list[str]:
    """The arrays of the demonstration packet's ``trajectory.npz`` (written for sampled
    instances of every family; T is the number of actions)."""
    shapes: dict[str, dict[str, str]] = {}
    for i in range(SAMPLES):
        scenario = plugin.make_scenario(seed=i, split=split, params={"demo_frames": False},
                                        index=i)
        family = Track2Scenario.of(scenario).family
        with tempfile.TemporaryDirectory(prefix="eagc-doc-") as tmp:
            plugin.write_inputs(scenario, Path(tmp))
            with np.load(next(Path(tmp).rglob("trajectory.npz"))) as z:
                steps = len(z["actions"]) if "actions" in z.files else -1
                for key in z.files:
                    a = z[key]
                    lead = {steps: "T", steps + 1: "T+1"}.get(a.shape[0], str(a.shape[0])) \
                        if a.shape else ""
                    dims = " × ".join([lead, *map(str, a.shape[1:])]) if a.shape else "scalar"
                    shapes.setdefault(key, {})[family] = f"{a.dtype} {dims}"
    rows = ["| array | dtype and shape |", "|---|---|"]
    for key, by in shapes.items():
        kinds = set(by.values())
        cell = next(iter(kinds)) if len(kinds) == 1 else "; ".join(
            f"{f}: {v}" for f, v in sorted(by.items()))
        rows.append(f"| `{key}` | {cell} |")
    return ["The demonstration packet's `trajectory.npz` (`$EAGC_INPUT/demo`, beside "
            "`manifest.json`, [`DemoManifest`](json/demo_manifest.json)); T is the number "
            "of actions:", "", *rows, ""]
