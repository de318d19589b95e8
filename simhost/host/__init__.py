"""What organizers run: the sim host that serves one episode over Zenoh (``SimHost``), the
episode interface a world implements (``TrackEpisode``), the MCAP recorder of an episode and
the typed reader of its records. Needs the ``sim`` extra (MuJoCo, mcap).

What other packages may import is ``__all__``; each name loads its module on first use, so
that importing this package (a track plugin does, for ``TrackEpisode``) loads neither Zenoh
nor mcap:

- the episode a world serves: ``TrackEpisode``, ``StageSpec``, ``StageEnd``,
  ``Observation``, ``StepOutcome``, ``Pose``, ``EpisodeOutcome``; the checked action
  (``check_action``, ``ActionError``);
- the host: ``SimHost``, ``HostConfig``, ``HostOutcome``, ``HostProgress``,
  ``EpisodeRecorder``; its log ``McapRecorder``; PNG files (``encode_png``, ``write_png``);
- the log read back (``read_records``, ``read_scenario``, ``parse_event``): each topic's
  model (``ScenarioRecord``, the requests, ``SmallTensors``, the events of
  ``HostEventModel``, ``StateHash``, ``FullState``, ``OutputFile``, the Foxglove images and
  transforms), each message a ``Record``; ``McapRecordError``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_MODULES = {
    "simhost.host._episode": ("EpisodeOutcome", "Observation", "Pose", "StageEnd", "StageSpec",
                              "StepOutcome", "TrackEpisode"),
    "simhost.host._actions": ("ActionError", "check_action"),
    "simhost.host._host": ("EpisodeRecorder", "HostConfig", "HostOutcome", "HostProgress",
                           "SimHost"),
    "simhost.host._mcap": ("McapRecorder",),
    "simhost.host._png": ("encode_png", "write_png"),
    "simhost.host._records": (
        "TOPICS", "AnswerRequest", "AttemptEndEvent", "CompressedImage", "EndStageRequest",
        "EpisodeEndEvent", "ExceptionArmedEvent", "ExceptionEvent", "ExceptionObservableEvent",
        "ExceptionSkippedEvent", "FrameTransforms", "FullState", "HelloRequest",
        "HostEventModel", "HostOpenEvent", "InternalErrorEvent", "McapRecordError",
        "OtherEvent", "OutputFile", "PosesInFrame", "ProtocolErrorEvent", "RawImage", "Record",
        "RequestRecord", "ResetRequest", "ScenarioRecord", "SmallTensors", "StageEndEvent",
        "StageStartEvent", "StateHash", "StepRequest", "parse_event", "read_records",
        "read_scenario",
    ),
}
_EXPORTS = {name: module for module, names in _MODULES.items() for name in names}

__all__ = [
    "TOPICS",
    "ActionError",
    "AnswerRequest",
    "AttemptEndEvent",
    "CompressedImage",
    "EndStageRequest",
    "EpisodeEndEvent",
    "EpisodeOutcome",
    "EpisodeRecorder",
    "ExceptionArmedEvent",
    "ExceptionEvent",
    "ExceptionObservableEvent",
    "ExceptionSkippedEvent",
    "FrameTransforms",
    "FullState",
    "HelloRequest",
    "HostConfig",
    "HostEventModel",
    "HostOpenEvent",
    "HostOutcome",
    "HostProgress",
    "InternalErrorEvent",
    "McapRecordError",
    "McapRecorder",
    "Observation",
    "OtherEvent",
    "OutputFile",
    "Pose",
    "PosesInFrame",
    "ProtocolErrorEvent",
    "RawImage",
    "Record",
    "RequestRecord",
    "ResetRequest",
    "ScenarioRecord",
    "SimHost",
    "SmallTensors",
    "StageEnd",
    "StageEndEvent",
    "StageSpec",
    "StageStartEvent",
    "StateHash",
    "StepOutcome",
    "StepRequest",
    "TrackEpisode",
    "check_action",
    "encode_png",
    "parse_event",
    "read_records",
    "read_scenario",
    "write_png",
]

if TYPE_CHECKING:
    from simhost.host._actions import ActionError, check_action
    from simhost.host._episode import (
        EpisodeOutcome,
        Observation,
        Pose,
        StageEnd,
        StageSpec,
        StepOutcome,
        TrackEpisode,
    )
    from simhost.host._host import (
        EpisodeRecorder,
        HostConfig,
        HostOutcome,
        HostProgress,
        SimHost,
    )
    from simhost.host._mcap import McapRecorder
    from simhost.host._png import encode_png, write_png
    from simhost.host._records import (
        TOPICS,
        AnswerRequest,
        AttemptEndEvent,
        CompressedImage,
        EndStageRequest,
        EpisodeEndEvent,
        ExceptionArmedEvent,
        ExceptionEvent,
        ExceptionObservableEvent,
        ExceptionSkippedEvent,
        FrameTransforms,
        FullState,
        HelloRequest,
        HostEventModel,
        HostOpenEvent,
        InternalErrorEvent,
        McapRecordError,
        OtherEvent,
        OutputFile,
        PosesInFrame,
        ProtocolErrorEvent,
        RawImage,
        Record,
        RequestRecord,
        ResetRequest,
        ScenarioRecord,
        SmallTensors,
        StageEndEvent,
        StageStartEvent,
        StateHash,
        StepRequest,
        parse_event,
        read_records,
        read_scenario,
    )


def __getattr__(name: str) -> Any:
    """A public name, from its module (loaded on first use)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'simhost.host' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
