"""Generate ``schemas/json/*.json`` from the models (never edit those files by hand)."""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import BaseModel, TypeAdapter

from schemas._campaign import CampaignSpec
from schemas._demo import DemoManifest
from schemas._disclosure import ResourceDisclosure
from schemas._files import LogRecord, TaskModel, WorldModel
from schemas._protocol import Reply, Request
from schemas._result import EpisodeResult, ScoreCard

JSON_DIR = Path(__file__).with_name("json")

TARGETS: dict[str, object] = {
    "protocol_request": Request,
    "protocol_reply": Reply,
    "world_model": WorldModel,
    "task_model": TaskModel,
    "demo_manifest": DemoManifest,
    "episode_log_record": LogRecord,
    "campaign": CampaignSpec,
    "resource_disclosure": ResourceDisclosure,
    "episode_result": EpisodeResult,
    "score_card": ScoreCard,
}


def render() -> dict[str, str]:
    """File name → text of every generated schema."""
    out = {}
    for name, target in TARGETS.items():
        if isinstance(target, type) and issubclass(target, BaseModel):
            schema = target.model_json_schema()
        else:
            schema = TypeAdapter(target).json_schema()
        schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": name, **schema}
        out[f"{name}.json"] = json.dumps(schema, indent=2, sort_keys=True) + "\n"
    return out


def write(directory: Path = JSON_DIR) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for fname, text in render().items():
        p = directory / fname
        p.write_text(text)
        paths.append(p)
    return paths
