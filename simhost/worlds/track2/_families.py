"""The family registry: which :class:`FamilyTask` implements which family."""

from __future__ import annotations

from . import _assembly, _insertion, _opening, _rotation, _tool_use
from ._config import BenchConfig
from ._family import FamilyTask
from ._params import InstanceParams
from ._truth import TaskTruth

TASKS: dict[str, type[FamilyTask]] = {
    "insertion": _insertion.InsertionTask,
    "rotation": _rotation.RotationTask,
    "assembly": _assembly.AssemblyTask,
    "opening": _opening.OpeningTask,
    "tool_use": _tool_use.ToolUseTask,
}


def make_task(params: InstanceParams, config: BenchConfig | None = None) -> FamilyTask:
    """The family task object for ``params`` under ``config`` (not yet bound to a simulation)."""
    return TASKS[params.family](params, config)


def family_step_cap(family: str) -> int:
    """The step cap of one attempt of ``family`` (its expert needs well under it)."""
    return TASKS[family].max_steps


def task_truth(params: InstanceParams, config: BenchConfig | None = None) -> TaskTruth:
    """Stages, state variables, constraints, preconditions and success criteria of ``params``
    under the split's ``config`` (its tolerances; default: the dev split's)."""
    return make_task(params, config).truth()
