"""Track 2's score (paper eq. 3) and the task-model check. Pure functions, no MuJoCo.

``S = 0.45 S_succ + 0.20 S_adapt + 0.15 S_gen + 0.10 S_model + 0.10 S_stab``, each in [0, 1]:

- ``success``: 1 if an attempt succeeded.
- ``adaptation``: 0 without success; else ``0.6 a + 0.4 t`` with ``a = (A - k + 1) / A`` for
  success at attempt ``k`` of ``A`` (1, 2/3, 1/3) and ``t = 1 - min(1, T / T_ref)``, ``T``
  the adaptation time (reception and parsing stages plus the execution time not spent
  stepping the simulator: the agent's own thinking) and ``T_ref`` the official reception
  and parsing budgets (25 min; a scaled local run therefore gets an optimistic ``t``).
- ``generalization``: the best progress any attempt reached (1 on success; the bench's
  ``(stage index + fraction) / stages``) times ``0.5 + 0.5 min(1, d / D_REF)``, ``d`` the
  instance's distance from the demonstrated source: far instances count in full, the
  demonstrated instance itself half.
- ``task_model``: ``task_model.json`` (the final one, else the latest valid stage snapshot)
  against the hidden instance's truth: 0 if the family is wrong or missing, else the mean of
  five parts — stages (longest common subsequence over the longer list), variables (F1 of
  names), constraints, preconditions (Jaccard of predicates per stage) and success criteria
  (op and value), each summed over the truth's items and divided by the larger of the two
  counts, so padding a model with guesses costs. Values compare by type: equal bools and
  strings (case-insensitive), numbers by ``1 - |error| / (0.2 |truth| + 0.002)``, lists
  element by element.
- ``stability``: 0 without an execution step; else ``1 - penalty``: 0.25 per drop, 0.1 per
  simulator warning, plus 2x the fraction of steps with excess contact force (> 25 N), 1x
  the fraction at a hand joint limit, 1x the fraction of jerky commands (a motion component
  changing by more than 1.2 in a step) and 2x the share of invalid or refused requests.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from schemas import TaskModel

WEIGHTS = {"success": 0.45, "adaptation": 0.20, "generalization": 0.15, "task_model": 0.10,
           "stability": 0.10}
OFFICIAL_ADAPT_S = (5 + 20) * 60.0
D_REF = 0.35
MODEL_PARTS = ("stages", "variables", "constraints", "preconditions", "success")


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


def model_parts(model: TaskModel | None, truth: Mapping[str, Any]) -> dict[str, float]:
    """The five parts of the task-model score (all 0 for a missing or wrong-family model)."""
    if model is None or model.family != truth["family"]:
        return dict.fromkeys(MODEL_PARTS, 0.0)
    t_stages = list(truth["stages"])
    stages = _lcs(model.stages, t_stages) / max(len(model.stages), len(t_stages), 1)
    variables = _f1({v.name for v in model.variables},
                    {v["name"] for v in truth["state_variables"]})

    pred_c = {c.name: c.value for c in model.constraints}
    t_cons = truth["constraints"]
    cons = sum(close(pred_c[c["name"]], c["value"]) for c in t_cons if c["name"] in pred_c)
    constraints = cons / max(len(t_cons), len(pred_c), 1)

    pred_p: dict[str, set[str]] = {}
    for p in model.preconditions:
        pred_p.setdefault(p.stage, set()).update(p.requires)
    t_pre: Mapping[str, list[str]] = truth["preconditions"]
    jac = 0.0
    for stage, req in t_pre.items():
        got, want = pred_p.get(stage, set()), set(req)
        jac += len(got & want) / len(got | want) if got | want else 1.0
    preconditions = jac / max(len(t_pre), len(pred_p), 1)

    t_succ = truth["success"]
    hit = 0.0
    for c in t_succ:
        hit += max((close(p.value, c["value"]) for p in model.success_criteria
                    if p.variable == c["variable"] and p.op == c["op"]), default=0.0)
    success = hit / max(len(t_succ), len(model.success_criteria), 1)
    return {"stages": stages, "variables": variables, "constraints": constraints,
            "preconditions": preconditions, "success": success}


def model_score(model: TaskModel | None, truth: Mapping[str, Any]) -> float:
    """``S_model`` in [0, 1]."""
    parts = model_parts(model, truth)
    return sum(parts.values()) / len(parts)


def adaptation(outcome: Mapping[str, Any]) -> float:
    k = outcome.get("success_attempt")
    if not k:
        return 0.0
    n = int(outcome.get("max_attempts") or 3)
    a = (n - int(k) + 1) / n
    t = 1.0 - min(1.0, float(outcome.get("adapt_time_s") or 0.0) / OFFICIAL_ADAPT_S)
    return 0.6 * a + 0.4 * t


def generalization(outcome: Mapping[str, Any], distance: float) -> float:
    progress = 1.0 if outcome.get("success") else float(outcome.get("best_progress") or 0.0)
    return min(1.0, max(0.0, progress)) * (0.5 + 0.5 * min(1.0, max(0.0, distance) / D_REF))


def stability(outcome: Mapping[str, Any], invalid: int) -> float:
    n = int(outcome.get("steps") or 0)
    if n <= 0:
        return 0.0
    o = {k: float(outcome.get(k) or 0) for k in
         ("drops", "sim_warnings", "excess_force_steps", "limit_steps", "jerk_steps")}
    penalty = (0.25 * o["drops"] + 0.1 * o["sim_warnings"] + 2.0 * o["excess_force_steps"] / n
               + o["limit_steps"] / n + o["jerk_steps"] / n + 2.0 * invalid / (n + invalid))
    return max(0.0, 1.0 - penalty)


def attempts_needed(outcome: Mapping[str, Any]) -> int:
    """The attempt that succeeded, or all the attempts allowed (a failure needs them all)."""
    return int(outcome.get("success_attempt") or outcome.get("max_attempts") or 3)
