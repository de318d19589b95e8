"""The imitation policy (T-OSVI style): one demonstration in, actions out, no world model.

The policy attends to the demonstration through a moving pointer: at every step it finds
the demonstration's observation nearest to the current one among the next few (the phase),
takes the demonstration's action there and adds a learned correction — a linear map of how
the current situation differs from the demonstration's at that phase::

    k_t = argmin_{j in [k_{t-1}, k_{t-1} + LOOKAHEAD]} || s(o_t) - s(d_j) ||
    a_t = clip(a_demo(k_t) + W_family^T [s(o_t) - s(d_{k_t}), 1], -1, 1)

``s(o)`` is an object-centric state: every part's position relative to the hand, in the
hand's frame (rows of ``parts``; absent rows zero), the finger opening and the two finger
contacts. ``W`` is fitted offline by ridge regression on expert rollouts (``train.py``).
Numpy only; used both by the agent and by the training script.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

ROWS = 6
LOOKAHEAD = 3
DIM = 3 * ROWS + 3


def state(proprio: np.ndarray, parts: np.ndarray) -> np.ndarray:
    """``s(o)``: the object-centric state of one observation."""
    p = np.asarray(proprio, dtype=float)
    rows = np.zeros((ROWS, 10))
    parts = np.asarray(parts, dtype=float)
    rows[: min(ROWS, len(parts))] = parts[:ROWS]
    c, s = math.cos(p[3]), math.sin(p[3])
    d = rows[:, 1:4] - p[:3]
    rel = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)
    rel *= rows[:, :1] > 0.5
    return np.concatenate([rel.ravel(), [p[4] / 0.09, p[5], p[6]]])


def features(current: np.ndarray, demo: np.ndarray) -> np.ndarray:
    """The regression input: the difference of two states, and a bias."""
    return np.append(current - demo, 1.0)


class Policy:
    """One demonstration's policy for one episode attempt."""

    def __init__(self, weights: np.ndarray, demo_states: np.ndarray,
                 demo_actions: np.ndarray) -> None:
        self.w = weights
        self.states = demo_states
        self.actions = demo_actions
        self.k = 0

    def reset(self) -> None:
        self.k = 0

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        s = state(obs["proprio"], obs["parts"])
        last = len(self.actions) - 1
        window = self.states[self.k: min(self.k + LOOKAHEAD, last) + 1]
        self.k = min(last, self.k + int(np.argmin(np.linalg.norm(window - s, axis=1))))
        a = self.actions[self.k] + features(s, self.states[self.k]) @ self.w
        self.k = min(last, self.k + 1)
        return np.clip(a, -1.0, 1.0).astype(np.float32)

    @property
    def done(self) -> bool:
        return self.k >= len(self.actions) - 1
