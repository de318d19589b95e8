"""Zenoh configuration and key expressions shared by the sim host and the agent client.

Keys are versioned and per episode: ``eagc/v1/<episode>/agent/{req,rep,alive,host_alive}``,
where ``<episode>`` is an opaque random id. The host listens on a unix socket; the agent
connects. Imports only zenoh (it runs inside team containers).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

import zenoh

KEY_ROOT = "eagc/v1"
_EPISODE_RE = re.compile(r"^[A-Za-z0-9_-]{4,64}$")


def check_episode_id(episode: str) -> str:
    if not _EPISODE_RE.match(episode):
        raise ValueError(f"episode id {episode!r} must be 4-64 characters of [A-Za-z0-9_-]")
    return episode


@dataclass(frozen=True)
class EpisodeKeys:
    """The agent-facing key expressions of one episode (the only keys its session carries)."""

    #: Requests: the agent publishes, the host subscribes.
    req: str
    #: Replies: the host publishes, the agent subscribes.
    rep: str
    #: The agent's liveliness token; the host watches it (its loss ends the episode).
    alive: str
    #: The host's liveliness token; the agent watches it (its loss: the host is gone).
    host_alive: str


def keys(episode: str) -> EpisodeKeys:
    """The agent-facing keys of one episode."""
    base = f"{KEY_ROOT}/{check_episode_id(episode)}/agent"
    return EpisodeKeys(req=f"{base}/req", rep=f"{base}/rep", alive=f"{base}/alive",
                       host_alive=f"{base}/host_alive")


def _base_config(mode: str) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    return conf


def host_config(episode: str, endpoints: list[str]) -> zenoh.Config:
    """The sim host's session: listens, admin space off, access control default-deny.

    The only keys allowed through, in either direction, are this episode's agent keys; the
    host's session carries nothing else, so a probe (``get("**")``, a subscription to ``**``,
    the admin space) learns nothing beyond them.
    """
    conf = _base_config("peer")
    conf.insert_json5("listen/endpoints", json.dumps(endpoints))
    conf.insert_json5("connect/endpoints", "[]")
    conf.insert_json5("adminspace/enabled", "false")
    # No shared memory: a sandboxed agent has no shared IPC anyway, and each session that
    # negotiated it left the serving process holding a segment in /dev/shm and an fd (seen
    # in the soak benchmark's long-lived Ray workers).
    conf.insert_json5("transport/shared_memory/enabled", "false")
    allowed = f"{KEY_ROOT}/{check_episode_id(episode)}/agent/**"
    acl = {
        "enabled": True,
        "default_permission": "deny",
        "rules": [
            {
                "id": "episode",
                "messages": [
                    "put",
                    "delete",
                    "declare_subscriber",
                    "liveliness_token",
                    "declare_liveliness_subscriber",
                    "liveliness_query",
                ],
                "flows": ["ingress", "egress"],
                "permission": "allow",
                "key_exprs": [allowed],
            }
        ],
        "subjects": [{"id": "everyone"}],
        "policies": [{"rules": ["episode"], "subjects": ["everyone"]}],
    }
    conf.insert_json5("access_control", json.dumps(acl))
    return conf


def agent_config(endpoint: str) -> zenoh.Config:
    """The agent's session: connects to the host's endpoint, nothing else."""
    conf = _base_config("peer")
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("listen/endpoints", "[]")
    # Without this, opening the session sometimes waits 0.5 s for scouting that is off anyway.
    conf.insert_json5("scouting/delay", "0")
    return conf
