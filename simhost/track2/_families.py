"""The family registry: which :class:`FamilyTask` implements which family."""

from __future__ import annotations

from . import _assembly, _insertion, _opening, _rotation, _tool_use
from ._family import FamilyTask
from ._params import InstanceParams

TASKS: dict[str, type[FamilyTask]] = {
    "insertion": _insertion.InsertionTask,
    "rotation": _rotation.RotationTask,
    "assembly": _assembly.AssemblyTask,
    "opening": _opening.OpeningTask,
    "tool_use": _tool_use.ToolUseTask,
}


def make_task(params: InstanceParams) -> FamilyTask:
    """The family task object for ``params`` (not yet bound to a simulation)."""
    return TASKS[params.family](params)
