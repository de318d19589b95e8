"""What the detector reports and what the odometry says: the sensor model of a split.

From the exact, visible detections of ``_sensors.detect`` the detector drops some (a miss
rate growing with distance), blurs the position of the rest (Gaussian noise growing with
distance) and reports some things as a look-alike category or colour (``CONFUSABLE``,
``CONFUSABLE_COLOURS``) when they are seen from afar. A detector's mistakes come from how a
thing looks, not from chance: which things are confusable, what they read as and from
which distance on are drawn once per episode (``look_alikes``), so a thing reads the same
way every time it is seen from beyond its distance, and right from closer. Votes over many
distant looks do not correct it; a closer look does. The odometry integrates each move's
true motion with errors proportional to the distance driven and the angle turned, so its
estimate drifts.

Every draw comes from ``numpy.random.default_rng([noise_seed, ...])``: the look-alikes from
one generator per episode, misses and noise from one per step and purpose, each drawing a
fixed-size block for every possible instance id whatever is visible. So the same seed and
the same actions give the same observations, however often a step's detections are
recomputed, and a saved state (which holds the step count, the noise seed and the
odometry) continues bit for bit.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ._catalogue import CONFUSABLE, CONFUSABLE_COLOURS, MAX_IDS
from ._config import HouseEnvConfig
from ._sensors import Detection

_DETECTION_STREAM = 0
_ODOMETRY_STREAM = 1
_LOOK_ALIKE_STREAM = 2
_BIG = ("door", "furniture", "container")


class LookAlike(NamedTuple):
    """How one thing reads from afar in an episode: the look-alike category and colour it is
    reported as (None: it reads right) and the distance beyond which each is wrong."""

    category: str | None
    colour: str | None
    beyond_category: float
    beyond_colour: float


@functools.lru_cache(maxsize=64)
def _draws(noise_seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng([noise_seed, _LOOK_ALIKE_STREAM])
    return tuple(rng.random(MAX_IDS) for _ in range(6))


def look_alikes(exact: list[Detection], config: HouseEnvConfig, noise_seed: int
                ) -> dict[int, LookAlike]:
    """How each visible entity reads from afar (drawn per episode, keyed by its id)."""
    u_cat, pick_cat, at_cat, u_col, pick_col, at_col = _draws(noise_seed)
    lo, hi = config.confusion_beyond
    out: dict[int, LookAlike] = {}
    for d in exact:
        k = d.id
        big = d.kind in _BIG
        scale = (config.sensing_range / config.item_range) if big and config.item_range else 1.0
        category: str | None = None
        alike = CONFUSABLE.get(d.category, ())
        if alike and u_cat[k] < config.category_confusion * (0.5 if big else 1.0):
            category = alike[min(int(pick_cat[k] * len(alike)), len(alike) - 1)]
        colour: str | None = None
        alike = CONFUSABLE_COLOURS.get(d.colour, ())
        if alike and u_col[k] < config.colour_confusion * (0.5 if big else 1.0):
            colour = alike[min(int(pick_col[k] * len(alike)), len(alike) - 1)]
        out[k] = LookAlike(category, colour, scale * (lo + (hi - lo) * float(at_cat[k])),
                           scale * (lo + (hi - lo) * float(at_col[k])))
    return out


def perceive(
    exact: list[Detection], config: HouseEnvConfig, noise_seed: int, step: int
) -> list[Detection]:
    """What the detector reports of the visible entities (nearest first, as given)."""
    if config.exact or not exact:
        return exact
    rng = np.random.default_rng([noise_seed, step, _DETECTION_STREAM])
    u_miss = rng.random(MAX_IDS)
    noise = rng.standard_normal((MAX_IDS, 2))
    alikes = look_alikes(exact, config, noise_seed)
    a_miss, b_miss = config.miss_rate
    a_pos, b_pos = config.position_noise
    out = []
    for d in exact:
        k = d.id
        big = d.kind in _BIG
        p_miss = min(0.9, a_miss + b_miss * d.distance) * (1 / 3 if big else 1.0)
        if u_miss[k] < p_miss:
            continue
        sigma = a_pos + b_pos * d.distance
        rel = (d.rel_pos[0] + sigma * float(noise[k, 0]), d.rel_pos[1] + sigma * float(noise[k, 1]))
        a = alikes[k]
        category = a.category if a.category and d.distance > a.beyond_category else d.category
        colour = a.colour if a.colour and d.distance > a.beyond_colour else d.colour
        out.append(replace(d, rel_pos=rel, category=category, colour=colour,
                           distance=math.hypot(*rel)))
    return out


def drift(
    estimate: tuple[float, float, float],
    before: tuple[float, float, float],
    after: tuple[float, float, float],
    config: HouseEnvConfig,
    noise_seed: int,
    step: int,
) -> tuple[float, float, float]:
    """The odometry estimate after the robot moved from ``before`` to ``after`` (true poses).

    The true motion, in the robot's frame at ``before``, is scaled and rotated by random
    errors and added to the estimate in the estimate's own frame; exact when the config has
    no odometry noise (then the estimate is the true pose).
    """
    if config.odometry_noise == (0.0, 0.0):
        return after
    sigma_t, sigma_r = config.odometry_noise
    x0, y0, th0 = before
    dx, dy = after[0] - x0, after[1] - y0
    c, s = math.cos(th0), math.sin(th0)
    along, across = c * dx + s * dy, -s * dx + c * dy
    turned = math.remainder(after[2] - th0, math.tau)
    driven = math.hypot(along, across)
    e = np.random.default_rng([noise_seed, step, _ODOMETRY_STREAM]).standard_normal(3)
    along += sigma_t * driven * float(e[0])
    across += sigma_t * driven * float(e[1])
    turned += sigma_r * (abs(turned) + 0.2 * driven) * float(e[2])
    ex, ey, eth = estimate
    ce, se = math.cos(eth), math.sin(eth)
    yaw = math.remainder(eth + turned, math.tau)
    return (ex + ce * along - se * across, ey + se * along + ce * across, yaw)
