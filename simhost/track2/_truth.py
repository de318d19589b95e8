"""``task_truth``: the ground truth a team's ``task_model.json`` is compared with.

Shape (every family)::

    {
      "version": "eagc-truth/v1",
      "family": "insertion",
      "stages": ["reach", "grasp", ...],                     # ordered key stages
      "state_variables": [{"name": "peg_pose", "type": "pose", "part": "peg"}, ...],
      "constraints": [{"name": "clearance", "value": 0.004}, ...],
      "preconditions": {"transport": ["peg_grasped"], ...},  # stage -> predicates
      "success": [{"variable": "insertion_depth", "op": ">=", "value": 0.0196}, ...],
      "goal": {"depth_frac": 0.7}                           # the instance's goal parameters
    }

Vocabulary per family (names are fixed; ``partK`` for K = 1..n_parts, ``<m>`` the moving
part of an opening task: ``drawer``, ``cover`` or ``lid``):

- insertion — stages ``reach grasp transport align insert release``; variables ``ee_pose
  gripper_width peg_pose hole_pose peg_grasped peg_lifted peg_hole_offset peg_yaw_error
  insertion_depth``; constraints ``peg_shape clearance yaw_symmetry hole_depth peg_upright
  max_grip_width``.
- rotation — stages ``reach grasp turn release``; variables ``ee_pose gripper_width
  knob_angle knob_grasped angle_error``; constraints ``handle_kind rotation_axis
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
  (press) or ``puck_position puck_x tip_behind_puck`` (pull); constraints ``mechanism tool_slot
  tool_length distractor_present target_out_of_gripper_reach max_grip_width`` plus
  ``well_depth well_width press_depth`` or ``goal_x goal_tolerance``.

Predicates in ``preconditions`` are ``gripper_open``, ``gripper_at_<part>``,
``<part>_grasped``, ``<part>_lifted``, ``<part>_aligned``, ``<part>_inserted``,
``<part>_at_goal``, ``<part>_over_<support>``, ``<part>_placed``, ``tip_over_well``,
``tip_behind_puck``.
"""

from __future__ import annotations

from typing import Any

from ._families import make_task
from ._params import InstanceParams


def task_truth(params: InstanceParams) -> dict[str, Any]:
    """Stages, state variables, constraints, preconditions and success criteria of ``params``."""
    return make_task(params).truth()
