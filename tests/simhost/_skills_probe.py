"""A test agent for ``test_skills.py``: the public skills on a real episode, their outcomes
written as JSON to ``$SKILLS_PROBE_OUT``. It explores, then, during execution, asks for
what the host refuses (picking up furniture, opening a table) and for what it does
(fetching an object and putting it on a piece of furniture), and ends the episode."""

from __future__ import annotations

import dataclasses
import json
import math
import os

from simhost.client import OutputFiles, RemoteEnv
from simhost.client.skills import EXPLORED, Skills


def main() -> None:
    results: dict[str, object] = {}
    with RemoteEnv() as env:
        env.hello(agent="skills-probe/1")
        skills = Skills(env, env.reset())
        files = OutputFiles()
        files.log(step=0, stage="exploration", event="stage")
        while skills.explore_next().reason != EXPLORED and skills.ts.stage == "exploration":
            pass
        model = skills.model
        model.write(files)
        skills.end_stage()  # to planning
        skills.end_stage({"plan": {"subgoals": []}})  # to execution
        here = skills.explorer.pose[:2]
        tables = sorted((t for t in model.of_kind("furniture") if t.category == "table"),
                        key=lambda t: math.dist(t.position, here))
        items = sorted((t for t in model.of_kind("object") if t.room is not None
                        and skills.explorer.box_of(t) is None),
                       key=lambda t: math.dist(t.position, here))
        results["stage"] = skills.ts.stage
        results["go_to_room"] = skills.go_to(room=skills.explorer.room)
        results["pick_table"] = skills.fetch(tables[0].id)
        results["pick_table_host"] = skills.ts.action.reason if skills.ts.action else None
        results["open_table"] = skills.open(tables[0].id)
        results["open_table_host"] = skills.ts.action.reason if skills.ts.action else None
        results["place_unheld"] = skills.place(items[0].id, tables[0].id)
        results["unknown"] = skills.fetch(999_999)
        results["fetch"] = skills.fetch(items[0].id)
        results["held"] = skills.explorer.held
        results["item"] = items[0].id
        results["place"] = skills.place(items[0].id, tables[0].id)
        results["held_after"] = skills.explorer.held
        if not skills.ts.episode_over:
            skills.step({"primitive": "done"})
    out = {k: dataclasses.asdict(v) if dataclasses.is_dataclass(v) else v
           for k, v in results.items()}
    with open(os.environ["SKILLS_PROBE_OUT"], "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
