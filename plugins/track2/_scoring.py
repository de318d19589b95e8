"""Track 2's score (paper eq. 3) and the task-model check. Pure functions, no MuJoCo.

``S = 0.45 S_succ + 0.20 S_adapt + 0.15 S_gen + 0.10 S_model + 0.10 S_stab``, each in
[0, 1]; every component pays only for what the agent achieved:

- ``success``: 1 if an attempt succeeded.
- ``adaptation``: 0 without success; else ``0.6 a + 0.4 t`` with ``a = (A - k + 1) / A``
  for success at attempt ``k`` of ``A`` (1, 2/3, 1/3) and ``t = 1 - min(1, T / T_granted)``:
  ``T`` the adaptation time (reception and parsing stages plus the execution time not spent
  stepping the simulator: the agent's own thinking) and ``T_granted`` the reception and
  parsing budgets the episode was actually granted (after a campaign's time scale; the
  official 25 minutes when unknown).
- ``generalization``: the progress made from the start state, ``(peak - start) / (1 -
  start)`` for the best attempt, 1 on success (progress is the bench's ``(stage index +
  fraction) / stages``). The paper weights it by the instance's distance from the
  demonstration; a weight growing with distance pays more for the same outcome on a farther
  instance (measured: the hardest settings raised scores), so the same outcome scores the
  same at any distance here, and distance shows only in the leaderboard's metrics.
- ``task_model``: ``task_model.json`` (the final one, else the latest valid stage snapshot)
  against the hidden instance's truth: 0 if the family is wrong or missing, else a weighted
  mean of five parts — stages (longest common subsequence over the longer list), variables
  (F1 of names), preconditions (Jaccard of predicates per stage), each 0.1, and constraints
  and success criteria (op and value), each 0.35: the names are the public vocabulary, the
  values are what must be inferred. Each part is summed over the truth's items and divided by
  the larger of the two counts, so padding a model with guesses costs. Values compare by
  type: equal bools and strings (case-insensitive), numbers by ``1 - |error| / (0.2 |truth|
  + 0.002)``, lists element by element. Goals in the truth are relative to the attempt's
  start (a turn, not an absolute angle), so they can be inferred from the demonstration.
- ``stability``: ``gain * (1 - penalty)``, ``gain`` the generalization's progress (no credit
  for not moving): 0.25 per drop, 0.1 per simulator warning, plus 2x the fraction of steps
  with excess contact force (> 25 N), 1x the fraction at a hand joint limit, 1x the fraction
  of jerky commands (a motion component changing by more than 1.2 in a step) and 2x the
  share of invalid or refused requests.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from plugins.track2._outcome import Track2Outcome
from schemas import TaskModel
from simhost.worlds.track2 import TaskTruth

WEIGHTS = {"success": 0.45, "adaptation": 0.20, "generalization": 0.15, "task_model": 0.10,
           "stability": 0.10}
OFFICIAL_ADAPT_S = (5 + 20) * 60.0
MODEL_PARTS = ("stages", "variables", "constraints", "preconditions", "success")
MODEL_WEIGHTS = {"stages": 0.1, "variables": 0.1, "constraints": 0.35, "preconditions": 0.1,
                 "success": 0.35}


def close(pred: Any, true: Any) -> float:
    """How well a predicted value matches a true one, in [0, 1]."""
    if isinstance(true, bool):
        return float(isinstance(pred, bool) and pred == true)
    if isinstance(true, int | float):
        if isinstance(pred, bool) or not isinstance(pred, int | float) or not math.isfinite(pred):
            return 0.0
        return max(0.0, 1.0 - abs(pred - true) / (0.2 * abs(true) + 0.002))
    if isinstance(true, str):
        return float(isinstance(pred, str) and pred.strip().lower() == true.lower())
    if isinstance(true, list | tuple):
        if not isinstance(pred, list | tuple) or len(pred) != len(true):
            return 0.0
        if not true:
            return 1.0
        return sum(close(p, t) for p, t in zip(pred, true, strict=True)) / len(true)
    return float(pred == true)


def _lcs(a: Sequence[str], b: Sequence[str]) -> int:
    row = [0] * (len(b) + 1)
    for x in a:
        prev = 0
        for j, y in enumerate(b):
            cur = row[j + 1]
            row[j + 1] = prev + 1 if x == y else max(row[j + 1], row[j])
            prev = cur
    return row[-1]


def _f1(pred: set[str], true: set[str]) -> float:
    if not pred or not true:
        return float(pred == true)
    tp = len(pred & true)
    return 2 * tp / (len(pred) + len(true))


def model_parts(model: TaskModel | None, truth: TaskTruth) -> dict[str, float]:
    """The five parts of the task-model score (all 0 for a missing or wrong-family model)."""
    if model is None or model.family != truth.family:
        return dict.fromkeys(MODEL_PARTS, 0.0)
    t_stages = list(truth.stages)
    stages = _lcs(model.stages, t_stages) / max(len(model.stages), len(t_stages), 1)
    variables = _f1({v.name for v in model.variables}, {v.name for v in truth.state_variables})

    pred_c = {c.name: c.value for c in model.constraints}
    t_cons = truth.constraints
    cons = sum(close(pred_c[c.name], c.value) for c in t_cons if c.name in pred_c)
    constraints = cons / max(len(t_cons), len(pred_c), 1)

    pred_p: dict[str, set[str]] = {}
    for p in model.preconditions:
        pred_p.setdefault(p.stage, set()).update(p.requires)
    jac = 0.0
    for stage, req in truth.preconditions.items():
        got, want = pred_p.get(stage, set()), set(req)
        jac += len(got & want) / len(got | want) if got | want else 1.0
    preconditions = jac / max(len(truth.preconditions), len(pred_p), 1)

    hit = 0.0
    for c in truth.success:
        hit += max((close(p.value, c.value) for p in model.success_criteria
                    if p.variable == c.variable and p.op == c.op), default=0.0)
    success = hit / max(len(truth.success), len(model.success_criteria), 1)
    return {"stages": stages, "variables": variables, "constraints": constraints,
            "preconditions": preconditions, "success": success}


def model_score(model: TaskModel | None, truth: TaskTruth) -> float:
    """``S_model`` in [0, 1]: the weighted mean of the parts (``MODEL_WEIGHTS``)."""
    parts = model_parts(model, truth)
    return sum(MODEL_WEIGHTS[k] * v for k, v in parts.items())


def adaptation(o: Track2Outcome, granted_s: float = OFFICIAL_ADAPT_S) -> float:
    """``S_adapt``: attempts needed and adaptation time against the granted budget."""
    if not o.success_attempt:
        return 0.0
    n = max(1, o.max_attempts)
    a = (n - o.success_attempt + 1) / n
    t = 1.0 - min(1.0, o.adapt_time_s / max(granted_s, 1e-9))
    return 0.6 * a + 0.4 * t


def generalization(o: Track2Outcome) -> float:
    """``S_gen``: progress from the start state (1 on success)."""
    return 1.0 if o.success else o.gain


def stability(o: Track2Outcome, invalid: int) -> float:
    """``S_stab``: ``gain * (1 - penalty)``; 0 without progress."""
    n = o.steps
    if n <= 0:
        return 0.0
    penalty = (0.25 * o.drops + 0.1 * o.sim_warnings + 2.0 * o.excess_force_steps / n
               + o.limit_steps / n + o.jerk_steps / n + 2.0 * invalid / (n + invalid))
    return generalization(o) * max(0.0, 1.0 - penalty)


def granted_adapt_s(budgets: Mapping[str, float]) -> float:
    """The reception and parsing budgets an episode was granted (s, after its time scale)."""
    return budgets["demonstration"] + budgets["parsing"]
