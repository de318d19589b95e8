"""Split configurations: what the robot observes, how the bench behaves, how instances vary.

A split of Track 2 is a :class:`SplitConfig`: a :class:`BenchConfig` (the observation
channel, the tolerances and the per-attempt jitter, i.e. everything ``BenchEnv`` needs) and a
:class:`VariationConfig` (how a hidden instance is drawn around the demonstrated source).
Three presets (``SPLITS``):

- ``dev`` — today's public level for getting started: exact part poses and joint readings at
  every step, a goal vector that states target and tolerance, narrow parameter ranges, loose
  tolerances, an instance reset to exactly the same state between attempts;
- ``standard`` and ``challenge`` — the official splits: part poses measured by a camera-like
  channel (noise in mm and degrees, a lower rate, latency, hidden while the gripper occludes
  them, yaw only modulo the part's symmetry), no joint readings and no goal vector (the goal
  is the demonstration's: the same turn, the same fraction), RGB-D at
  ``OFFICIAL_IMAGE_SIZE``, wide
  parameter ranges with new shapes, a switched mechanism or turning direction now and then,
  grasps that can slip, tight tolerances, and a small pose jitter per attempt. ``challenge``
  is noisier, slower and farther from the source than ``standard``.

Every number here is part of the public rules; what stays hidden is the seeds.
"""

from __future__ import annotations

import difflib
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from ._errors import SplitConfigError


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class ObservationConfig(_Frozen):
    """How the robot observes the bench (``BenchEnv``'s observation channel).

    Proprioception (``proprio``) and the contact/force summary (``force``) are always exact.
    Part poses (``parts``) are measurements: every ``period_steps`` control steps the channel
    measures every part as it was ``latency_steps`` steps earlier, through a camera whose
    calibration to the robot is off by a rigid error constant for the episode (``calib_m``,
    ``calib_rad``: common to every part, so it cancels in relative poses but not against the
    robot's own exact proprioception), adds a bias constant for the episode per part
    (``pose_bias_m``, ``yaw_bias_rad``: a pose estimator's per-object error) — neither
    averages away — and Gaussian noise to its position (``pose_noise_m`` per axis) and yaw
    (``yaw_noise_rad``), and reports the yaw only modulo the part's symmetry when
    ``symmetric_yaw``. A part the gripper hides from the
    cameras (``occlusion``: from every one of the bench's three cameras, every line of sight
    to the part's sample points first meets the gripper) keeps its last measurement, and the
    row's ``age`` grows. All
    noise comes from the episode's seeded generator: the same seed, the same noise.
    """

    parts: bool = Field(True, description="Part pose rows in the observation (False: RGB-D "
                        "only).")
    pose_noise_m: float = Field(0.0, ge=0.0, le=0.02,
                                description="Std. dev. of the noise on each position axis (m).")
    yaw_noise_rad: float = Field(0.0, ge=0.0, le=0.2,
                                 description="Std. dev. of the noise on a part's yaw (rad).")
    pose_bias_m: float = Field(0.0, ge=0.0, le=0.02,
                               description="Std. dev. of a part's constant position error per "
                               "episode, horizontal axes (m; half of it vertically).")
    yaw_bias_rad: float = Field(0.0, ge=0.0, le=0.2,
                                description="Std. dev. of a part's constant yaw error per "
                                "episode (rad).")
    calib_m: float = Field(0.0, ge=0.0, le=0.02,
                           description="Std. dev. of the camera-to-robot calibration error per "
                           "episode, common to every part: a translation per horizontal axis "
                           "(m; half of it vertically).")
    calib_rad: float = Field(0.0, ge=0.0, le=0.05,
                             description="Std. dev. of the calibration's yaw error per episode "
                             "(rad): measured poses are turned by it about the table's origin.")
    period_steps: int = Field(1, ge=1, le=20,
                              description="Parts (and images) are measured every this many "
                              "control steps.")
    latency_steps: int = Field(0, ge=0, le=10,
                               description="A measurement shows the state this many control "
                               "steps before the observation.")
    occlusion: bool = Field(False, description="Parts the gripper hides keep their last "
                            "measurement.")
    symmetric_yaw: bool = Field(False, description="A part's yaw is reported modulo its "
                                "symmetry (a square peg looks the same turned by 90 degrees).")
    joint_readings: bool = Field(True, description="The 'joint' column holds the hinge angle or "
                                 "slide position of articulated parts (else 0).")
    goal_vector: bool = Field(True, description="The observation has 'goal', the task's stated "
                              "goal parameters.")
    rgbd: bool = Field(False, description="Render 'rgb' and 'depth' from the overview camera, "
                       "'rgb_front' and 'depth_front' from the front camera and 'rgb_top' "
                       "and 'depth_top' from the top camera.")
    segmentation: bool = Field(False, description="Also render 'segmentation', "
                               "'segmentation_front' and 'segmentation_top' (part ids).")
    image_size: tuple[int, int] = Field((96, 128), description="(height, width) of images "
                                        "(the official splits: OFFICIAL_IMAGE_SIZE).")


class Tolerances(_Frozen):
    """How close is close enough: the success tolerances of the families."""

    rotation_rad: float = Field(0.08, gt=0, description="Turned angle vs. the goal turn.")
    opening_frac: float = Field(0.08, gt=0, description="Opening fraction vs. the goal.")
    assembly_xy_m: float = Field(0.008, gt=0, description="A stacked part's centre vs. the one "
                                 "below (the first part: the tray clearance decides).")
    assembly_yaw_rad: float = Field(0.1, gt=0, description="A stacked part's yaw vs. the one "
                                    "below, modulo 90 degrees.")
    pull_m: float = Field(0.02, gt=0, description="The pulled puck's centre vs. the goal line.")


class BenchConfig(_Frozen):
    """Everything ``BenchEnv`` needs besides the instance: observation, rules, resets."""

    observation: ObservationConfig = ObservationConfig()
    tolerances: Tolerances = Tolerances()
    grip_slip: bool = Field(False, description="Finger contacts use the part's own friction "
                            "(else the fingers' high friction): a grasp can slip.")
    attempt_jitter_m: float = Field(0.0, ge=0.0, le=0.02,
                                    description="Std. dev. of a per-reset offset of every loose "
                                    "part and fixture (m), drawn from the reset's seed.")
    attempt_jitter_rad: float = Field(0.0, ge=0.0, le=0.3,
                                      description="Std. dev. of the per-reset yaw offset (rad); "
                                      "also the jitter of an articulated part's start.")
    demo_values: Literal["exact", "coarse"] = Field(
        "exact", description="What a demonstration's goal annotation says of the magnitude "
        "reached: 'exact' (the depth, turn, fraction, ... as a number) or 'coarse' (what an "
        "annotator states and the observations cannot show: an opening's fraction, to a "
        "tenth; every other magnitude is left to the observations).")


class VariationConfig(_Frozen):
    """How a hidden instance differs from the demonstrated source (``sample_instance``)."""

    difficulty: float = Field(0.5, ge=0.0, le=1.0, description="Spread of continuous values "
                              "around the source, as a fraction of their range.")
    source_spread: float = Field(0.3, ge=0.0, le=1.0, description="Spread of the demonstrated "
                                 "source around the canonical instance.")
    switch_probability: float = Field(0.6, ge=0.0, le=1.0, description="At difficulty 1, the "
                                      "chance a categorical parameter changes.")
    wide: bool = Field(False, description="Wide ranges and new shapes (else the dev ranges).")
    goal_from_source: bool = Field(False, description="Goal parameters are the source's: the "
                                   "same turn, the same fraction, the same depth.")
    mechanism_switch: float = Field(0.0, ge=0.0, le=1.0, description="Chance that a switchable "
                                    "parameter (tool mechanism, turning direction) changes.")


class SplitConfig(_Frozen):
    """One split of Track 2: the bench as the agent meets it, how instances vary, and the
    step budget of an attempt."""

    name: str
    bench: BenchConfig
    variation: VariationConfig
    budget_factor: float | None = Field(
        None, gt=1.0, description="An attempt's step budget is this many times the steps the "
        "feasibility expert needed on the instance (within the family's cap); None: the "
        "family's cap.")


OFFICIAL_IMAGE_SIZE = (384, 512)
"""(height, width) of the official splits' RGB-D, every camera: 512 x 384, the size at which
every present part at reset is at least 30 px across and 150 px in the camera that shows it
best (``tests/simhost/test_track2_cameras.py``)."""
_ROBOT = ObservationConfig(
    pose_noise_m=0.001, yaw_noise_rad=0.015, pose_bias_m=0.001, yaw_bias_rad=0.01,
    calib_m=0.003, calib_rad=0.005, period_steps=2, latency_steps=1, occlusion=True,
    symmetric_yaw=True, joint_readings=False, goal_vector=False, rgbd=True,
    image_size=OFFICIAL_IMAGE_SIZE,
)
BUDGET_FACTOR = 2.0
"""Official splits: an attempt may take twice the steps a system that knows the instance's
parameters needs through the same observation channel (the feasibility expert)."""
_TIGHT = Tolerances(rotation_rad=0.05, opening_frac=0.05, assembly_xy_m=0.005,
                    assembly_yaw_rad=0.08, pull_m=0.012)

SPLITS: dict[str, SplitConfig] = {
    "standard": SplitConfig(
        name="standard",
        bench=BenchConfig(observation=_ROBOT, tolerances=_TIGHT, grip_slip=True,
                          attempt_jitter_m=0.003, attempt_jitter_rad=0.04,
                          demo_values="coarse"),
        variation=VariationConfig(difficulty=0.4, source_spread=0.4, switch_probability=0.5,
                                  wide=True, goal_from_source=True, mechanism_switch=0.3),
        budget_factor=BUDGET_FACTOR,
    ),
    "challenge": SplitConfig(
        name="challenge",
        bench=BenchConfig(
            observation=_ROBOT.model_copy(update={
                "pose_noise_m": 0.0015, "yaw_noise_rad": 0.025, "pose_bias_m": 0.0015,
                "yaw_bias_rad": 0.017, "calib_m": 0.004, "calib_rad": 0.008,
                "period_steps": 3, "latency_steps": 2}),
            tolerances=_TIGHT, grip_slip=True, attempt_jitter_m=0.004, attempt_jitter_rad=0.06,
            demo_values="coarse"),
        variation=VariationConfig(difficulty=0.7, source_spread=0.5, switch_probability=0.6,
                                  wide=True, goal_from_source=True, mechanism_switch=0.45),
        budget_factor=BUDGET_FACTOR,
    ),
    "dev": SplitConfig(
        name="dev",
        bench=BenchConfig(),
        variation=VariationConfig(difficulty=0.5, source_spread=0.3),
    ),
}
"""The split presets, official ones first."""

SplitName = Literal["standard", "challenge", "dev"]


def split_config(name: str) -> SplitConfig:
    """The preset called ``name`` (``dev``, ``standard`` or ``challenge``)."""
    try:
        return SPLITS[name]
    except KeyError:
        hint = difflib.get_close_matches(str(name), list(SPLITS), n=1)
        did = f" Did you mean {hint[0]!r}?" if hint else ""
        raise SplitConfigError(
            f"unknown Track 2 split {name!r}.{did} Splits: {', '.join(SPLITS)}") from None
