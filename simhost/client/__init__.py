"""The agent-side client a team's container imports: ``from simhost.client import RemoteEnv``.

Needs only pydantic, eclipse-zenoh and numpy. One episode, one client::

    env = RemoteEnv()                    # endpoint and episode from EAGC_* variables
    spec = env.hello(agent="my-team/1.0")
    ts = env.reset()
    while not ts.episode_over:
        ts = env.step({"velocity": [0.5, 0.0]})
    env.close()

Every call sends one request and returns exactly one reply. Protocol errors (malformed,
stale, out-of-range, …) raise ``HostError``; an action the world refused is not an error,
it comes back in ``TimeStep.action`` with ``ok=False`` and a reason.

Every request carries an ``id`` that its reply echoes, so that a reply that answers
something else (a second reply to a resent ``hello``, the late reply to a request that
timed out) is never taken for the reply to the current request. The client watches the
host's liveliness token: when the host is gone (its process ended or was killed), a call
under way or the next one raises ``HostLost`` at once. A reply that does not come within
``timeout_s`` (60 s by default) raises ``TimeoutError``. The wire format is specified in
``schemas/PROTOCOL.md``.

``GymEnv`` (``GymEnv(RemoteEnv(), ...)``, or ``GymEnv()`` alone) offers the same episode
as a ``gymnasium.Env``-shaped object, for a policy written against the offline
environments (``simhost.client._gym_client``; loaded on first use, so that importing this
module never imports gymnasium); ``OFFLINE_DTYPES`` are the offline dtypes it restores
where the wire has none.

``CONFUSABLE`` and ``CONFUSABLE_COLOURS`` are Track 1's look-alike tables: the categories
and colours its detector may report instead of the true ones, when a thing is seen from
afar (``schemas/PROTOCOL.md``, Track 1 vocabulary).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from simhost.client._lookalikes import CONFUSABLE, CONFUSABLE_COLOURS
from simhost.client._outputs import OutputFileError, OutputFiles
from simhost.client._remote import DEFAULT_TIMEOUT_S, HostError, HostLost, RemoteEnv, TimeStep

if TYPE_CHECKING:
    from simhost.client._gym_client import (
        OFFLINE_DTYPES,
        GymClientError,
        GymEnv,
        StageEnd,
        StageRule,
    )

__all__ = [
    "CONFUSABLE",
    "CONFUSABLE_COLOURS",
    "DEFAULT_TIMEOUT_S",
    "OFFLINE_DTYPES",
    "GymClientError",
    "GymEnv",
    "HostError",
    "HostLost",
    "OutputFileError",
    "OutputFiles",
    "RemoteEnv",
    "StageEnd",
    "StageRule",
    "TimeStep",
]

_GYM_EXPORTS = ("OFFLINE_DTYPES", "GymClientError", "GymEnv", "StageEnd", "StageRule")


def __getattr__(name: str) -> Any:
    """The gymnasium-style client's names, loaded on first use (gymnasium if installed)."""
    if name in _GYM_EXPORTS:
        from simhost.client import _gym_client

        return getattr(_gym_client, name)
    raise AttributeError(f"module 'simhost.client' has no attribute {name!r}")
