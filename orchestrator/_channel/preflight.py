"""A submission's pre-flight episode: ``python -m orchestrator._channel.preflight``.

Runs one public episode of the image in the full sandbox, then the container contract
(``eagc test``'s checks), and prints one JSON line: ``{"ok": …, "summary": …, "checks":
[…], "infrastructure": …}``. A process of its own, so that the runner's pre-flight never
shares a process (or a MuJoCo context) with the campaign it runs beside it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="eagc-preflight")
    p.add_argument("--image", required=True)
    p.add_argument("--track", required=True)
    p.add_argument("--split", required=True)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--time-scale", type=float, default=0.1)
    p.add_argument("--max-steps", type=int, default=None)
    p.add_argument("--memory-mb", type=int, default=2048)
    p.add_argument("--runs", type=Path, required=True)
    args = p.parse_args(argv)

    from orchestrator._episode.agentcheck import contract_checks
    from orchestrator._episode.worker import EpisodeSpec, run_episode
    from orchestrator._runtimes.docker import DockerRuntime
    from schemas import Limits

    limits = Limits(time_scale=args.time_scale, memory_mb=args.memory_mb,
                    max_steps_per_stage=args.max_steps)
    spec = EpisodeSpec(track=args.track, image=args.image, seed=args.seed, split=args.split,
                       runs_dir=args.runs, limits=limits)
    result = run_episode(spec, DockerRuntime())
    checks = contract_checks(result)
    failed = [c for c in checks if c.ok is False]
    infra = result.status.failure_kind == "infra"
    if infra:
        summary = f"infrastructure: {(result.failure.message if result.failure else '')}"
    elif failed:
        summary = "; ".join(f"{c.name}: {c.detail}" for c in failed)
    else:
        summary = (f"one {args.split} episode (seed {args.seed}) meets the container "
                   f"contract ({result.status.value})")
    print(json.dumps({"ok": not failed and not infra, "infrastructure": infra,
                      "summary": summary[:1500], "status": result.status.value,
                      "episode": str(result.episode),
                      "checks": [{"name": c.name, "ok": c.ok, "detail": c.detail}
                                 for c in checks]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
