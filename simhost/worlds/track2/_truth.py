"""``TaskTruth``: the ground truth a team's ``task_model.json`` is compared with.

One typed model for every family (built by ``task_truth(params, config)`` of ``_families``)::

    TaskTruth(
      version="eagc-truth/v2", family="rotation",
      stages=("reach", "grasp", "turn", "release"),                # ordered key stages
      state_variables=(TruthVariable(name="knob_turn", type="angle", part="knob"), ...),
      constraints=(TruthConstraint(name="turn_direction", value="ccw"), ...),
      preconditions={"turn": ("knob_grasped",), ...},              # stage -> predicates
      success=(TruthCriterion(variable="knob_turn", op="within", value=[1.15, 1.25]), ...),
      goal={"turn": 1.2, "direction": "ccw"},                      # relative to the start
    )

Goals are stated relative to the start of an attempt, as the demonstration defines them: the
same turn (``knob_turn``, rad, signed: + counter-clockwise), the same opening fraction, the
same insertion depth; so an agent can infer them from one demonstration.

Vocabulary per family (names are fixed; ``partK`` for K = 1..n_parts, ``<m>`` the moving
part of an opening task: ``drawer``, ``cover`` or ``lid``):

- insertion — stages ``reach grasp transport align insert release``; variables ``ee_pose
  gripper_width peg_pose hole_pose peg_grasped peg_lifted peg_hole_offset peg_yaw_error
  insertion_depth``; constraints ``peg_shape clearance yaw_symmetry hole_depth peg_upright
  max_grip_width``.
- rotation — stages ``reach grasp turn release``; variables ``ee_pose gripper_width
  knob_angle knob_turn knob_grasped``; constraints ``handle_kind rotation_axis
  grasp_symmetry turn_direction turn_angle angle_tolerance max_grip_width``.
- assembly — stages ``reach_partK grasp_partK transport_partK place_partK``; variables
  ``ee_pose gripper_width tray_pose partK_pose partK_grasped partK_offset partK_yaw_error
  partK_placed``; constraints ``n_parts order part_half_widths part_height tray_clearance
  xy_tolerance yaw_tolerance yaw_symmetry max_grip_width``.
- opening — stages ``reach grasp open|close release``; variables ``ee_pose gripper_width
  <m>_pose <m>_opening <m>_grasped``; constraints ``mechanism joint_type joint_range
  direction opening_tolerance max_grip_width``.
- tool_use — stages ``reach_tool grasp_tool carry_tool press|pull``; variables ``ee_pose
  gripper_width tool_pose tool_tip_position tool_grasped`` plus ``button_travel tip_in_well``
  (press) or ``puck_position puck_goal_offset tip_behind_puck`` (pull); constraints
  ``mechanism tool_slot tool_length distractor_present target_out_of_gripper_reach
  max_grip_width`` plus ``well_depth well_width press_depth`` or ``goal_tolerance``.

Predicates in ``preconditions`` are ``gripper_open``, ``gripper_at_<part>``,
``<part>_grasped``, ``<part>_lifted``, ``<part>_aligned``, ``<part>_inserted``,
``<part>_at_goal``, ``<part>_over_<support>``, ``<part>_placed``, ``tip_over_well``,
``tip_behind_puck``.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from ._params import Family, Value

TRUTH_VERSION = "eagc-truth/v2"


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class TruthVariable(_Frozen):
    """A state variable the task depends on."""

    name: str
    type: Literal["pose", "position", "angle", "fraction", "length", "bool"]
    part: str | None = None


class TruthConstraint(_Frozen):
    """A geometric or physical fact of the instance."""

    name: str
    value: Any


class TruthCriterion(_Frozen):
    """One success condition; all of them must hold at once."""

    variable: str
    op: Literal[">=", "<=", "==", "within"]
    value: Any


class TaskTruth(_Frozen):
    """The true task model of one instance (organizer-only)."""

    version: Literal["eagc-truth/v2"] = TRUTH_VERSION
    family: Family
    stages: tuple[str, ...]
    state_variables: tuple[TruthVariable, ...]
    constraints: tuple[TruthConstraint, ...]
    preconditions: dict[str, tuple[str, ...]]
    success: tuple[TruthCriterion, ...]
    goal: dict[str, Value] = Field(default_factory=dict,
                                   description="The goal relative to the attempt's start.")

    def constraint(self, name: str) -> Any:
        """The value of constraint ``name`` (``KeyError`` if the family has none)."""
        for c in self.constraints:
            if c.name == name:
                return c.value
        raise KeyError(f"{self.family} truth has no constraint {name!r}")
