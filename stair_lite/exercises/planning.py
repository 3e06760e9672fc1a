"""Checkers for the exercises of notebook 05 (the planning loop).

Each ``check_*`` takes the learner's function, calls it on seeded random inputs (plus a few built to
expose one mistake each), compares the answers with an independent computation written here in
plain numpy, and raises ``AssertionError`` with a hint when they differ. Where a wrong answer matches
a common mistake (epsilon on the wrong term, a blend instead of a sum, a view that is not allowed,
0-based step numbers, rectangles instead of trapezoids, ...) the hint names it. On success a checker prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from .common import call as _call, compares_with, diagnose

# --------------------------------------------------------------------------------------------------
# Exercise 1: the exploration weight decides (Eq. 15)
# --------------------------------------------------------------------------------------------------
def _choice(score: np.ndarray, allowed: np.ndarray) -> int:
    return int(np.argmax(np.where(allowed, score, -np.inf)))


def _choose_variants(u_et, u_er, epsilon, allowed) -> dict[str, int]:
    """The right choice and the choices a few plausible mistakes make."""
    return {
        "right": _choice(u_et + epsilon * u_er, allowed),
        "no_exclusion": int(np.argmax(u_et + epsilon * u_er)),
        "eps_on_exploitation": _choice(epsilon * u_et + u_er, allowed),
        "convex": _choice((1.0 - epsilon) * u_et + epsilon * u_er, allowed),
        "exploitation_only": _choice(u_et, allowed),
        "exploration_only": _choice(u_er, allowed),
        "lowest": int(np.argmin(np.where(allowed, u_et + epsilon * u_er, np.inf))),
    }


_CHOOSE_HINTS = {
    "no_exclusion": "a candidate that is not allowed (too close to a visited view) must never be chosen, however high its U",
    "eps_on_exploitation": "epsilon weighs the EXPLORATION term: U = U_et + epsilon * U_er (Eq. 15)",
    "convex": "Eq. 15 adds epsilon * U_er to U_et; it does not blend them as (1 - epsilon) U_et + epsilon U_er",
    "exploitation_only": "you ignored epsilon and the exploration term: U = U_et + epsilon * U_er",
    "exploration_only": "you ignored the exploitation term: U = U_et + epsilon * U_er",
    "lowest": "the planner takes the view of HIGHEST utility among the allowed ones",
}


def _choose_cases(rng: np.random.Generator, n_random: int):
    """(U_et, U_er, epsilon, allowed): random ones, and hand-made ones where one mistake changes the answer."""
    cases = [
        # the best view overall is not allowed
        (np.array([5.0, 1.0, 2.0, 0.5]), np.array([10.0, 4.0, 3.0, 9.0]), 0.2, np.array([False, True, True, True])),
        # exploration decides at a large epsilon, exploitation at a small one
        (np.array([3.0, 1.0, 0.0]), np.array([3.0, 12.0, 5.0]), 0.5, np.ones(3, bool)),
        (np.array([3.0, 1.0, 0.0]), np.array([3.0, 12.0, 5.0]), 0.1, np.ones(3, bool)),
        (np.array([0.0, 2.0, 1.0]), np.array([8.0, 2.5, 6.0]), 0.0, np.ones(3, bool)),
    ]
    for _ in range(n_random):
        n = int(rng.integers(5, 120))
        u_er = rng.uniform(0.0, 100.0, size=n)
        u_et = u_er * rng.uniform(0.0, 1.0, size=n) ** 2  # exploitation counts a part of the same uncertainty
        allowed = rng.uniform(size=n) > 0.2
        allowed[rng.integers(0, n)] = True
        cases.append((u_et, u_er, float(rng.choice([0.0, 0.2, 0.5, 0.8, rng.uniform(0.0, 3.0)])), allowed))
    return cases


def _choose_reference(exploitation, exploration, epsilon, allowed) -> int:
    return _choice(np.asarray(exploitation) + epsilon * np.asarray(exploration), np.asarray(allowed, bool))


@compares_with(_choose_reference)
def check_choose_view(choose_view, n_random: int = 60, seed: int = 0) -> bool:
    """``choose_view(exploitation, exploration, epsilon, allowed)`` takes the candidates' U_et and U_er (N,), the
    exploration weight and a boolean mask (N,) of the allowed candidates, and returns the index (an int) of the
    allowed candidate of highest U = U_et + epsilon U_er (Eq. 15)."""
    cases = _choose_cases(np.random.default_rng(seed), n_random)
    answers = []
    for u_et, u_er, epsilon, allowed in cases:
        got = _call(choose_view, u_et.copy(), u_er.copy(), epsilon, allowed.copy())
        if got is None:
            raise AssertionError("choose_view returned None: fill in the function body (it still looks like the stub)")
        if np.ndim(got) != 0 or not float(got).is_integer():
            raise AssertionError(f"choose_view must return one integer index into the candidates, got {got!r}")
        if not 0 <= int(got) < len(u_et):
            raise AssertionError(f"choose_view returned index {int(got)}, but there are {len(u_et)} candidates")
        answers.append(int(got))
    per_case = [_choose_variants(*case) for case in cases]
    variants = {name: [v[name] for v in per_case] for name in per_case[0]}
    wrong = [i for i, (got, want) in enumerate(zip(answers, variants["right"])) if got != want]
    if wrong:
        i = wrong[0]
        u_et, u_er, epsilon, allowed = cases[i]
        got, want = answers[i], variants["right"][i]
        hint = (_CHOOSE_HINTS["no_exclusion"] if not allowed[got] else
                diagnose(answers, variants, _CHOOSE_HINTS, "compare with Eq. 15 on three candidates by hand, one of them not allowed"))
        raise AssertionError(
            f"choose_view picked candidate {got} (U_et {u_et[got]:.2f}, U_er {u_er[got]:.2f}), expected {want} "
            f"(U_et {u_et[want]:.2f}, U_er {u_er[want]:.2f}) at epsilon {epsilon:.2f}\nHint: {hint}")
    print(f"check_choose_view: {len(cases)} planning steps agree (exclusion, epsilon 0 to 3 and random cases)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: summarising a mission's curve
# --------------------------------------------------------------------------------------------------
def fake_records(rng: np.random.Generator, n: int = 10) -> list[dict]:
    """Mission-like step records (step 1..n) with a rising, noisy PSNR and F1, for checkers and tests."""
    psnr = 14.0 + np.cumsum(rng.uniform(-0.5, 2.0, size=n))
    f1 = np.clip(np.cumsum(rng.uniform(-0.03, 0.15, size=n)), 0.0, 1.0)
    return [{"step": i + 1, "psnr": float(psnr[i]), "f1": float(f1[i])} for i in range(n)]


def _first_step_reference(records, key, threshold):
    for r in records:
        if r[key] > threshold:
            return r["step"]
    return None


def _area_reference(records, key):
    x = np.array([r["step"] for r in records], float)
    y = np.array([r[key] for r in records], float)
    return float(np.sum((y[1:] + y[:-1]) / 2 * np.diff(x)))


def _curve_cases(rng: np.random.Generator, n_random: int):
    """(records, key, threshold) triples, including ones built to expose a single mistake."""
    cases = []
    base = fake_records(np.random.default_rng(1), 10)
    cases.append((base, "f1", base[0]["f1"] - 1e-3))  # already exceeded at step 1 (index 0 is falsy!)
    cases.append((base, "f1", 2.0))  # never exceeded
    cases.append((base, "psnr", base[4]["psnr"]))  # equal at step 5 is not "exceeds"
    up_down = [dict(r) for r in base]
    for r, v in zip(up_down, [0.1, 0.2, 0.6, 0.3, 0.7, 0.8, 0.4, 0.9, 0.95, 0.97]):
        r["f1"] = v
    cases.append((up_down, "f1", 0.5))  # exceeds at step 3, falls back, exceeds again
    for _ in range(n_random):
        records = fake_records(rng, int(rng.integers(2, 16)))
        key = "psnr" if rng.uniform() < 0.5 else "f1"
        values = np.array([r[key] for r in records])
        threshold = float(rng.uniform(values.min() - 0.1 * np.ptp(values), values.max()))
        cases.append((records, key, threshold))
    return cases


@compares_with(_first_step_reference)
def check_first_step_above(first_step_above, n_random: int = 100, seed: int = 0) -> bool:
    """``first_step_above(records, key, threshold)`` returns the step number (the record's ``"step"``: the
    number of measurements taken, 1 for the top view) at which ``record[key]`` first EXCEEDS (>) the
    threshold, or None if it never does."""
    rng = np.random.default_rng(seed)
    cases = _curve_cases(rng, n_random)
    for records, key, threshold in cases:
        got = _call(first_step_above, [dict(r) for r in records], key, threshold)
        want = _first_step_reference(records, key, threshold)
        if got == want and (got is None) == (want is None):
            continue
        values = [round(r[key], 4) for r in records]
        where = (f"for {key} = {values} and threshold {threshold:.4f} you returned {got!r}, expected {want!r} "
                 "(steps count measurements from 1)")
        index = next((i for i, r in enumerate(records) if r[key] > threshold), None)
        last = next((r["step"] for r in reversed(records) if r[key] > threshold), None)
        at_least = next((r["step"] for r in records if r[key] >= threshold), None)
        tie = any(r[key] == threshold for r in records)
        if want is None and got is not None:
            hint = "the curve never exceeds the threshold: return None (not 0, -1 or the last step)"
        elif tie and got == at_least:
            hint = "'exceeds' means strictly greater (>): a value equal to the threshold does not count"
        elif index is not None and got == index:
            hint = ("off by one: you returned the list index (0-based); return the step number record['step'], "
                    "which counts measurements from 1")
        elif got == last:
            hint = "you returned the LAST step above the threshold; the question is the FIRST"
        elif got is None:
            hint = "the curve does exceed the threshold: return its first step (careful: step 1 is a valid answer)"
        else:
            hint = ("check a three-step mission by hand: which step is the first above the threshold, and what the function "
                    "returns when none is")
        raise AssertionError(f"first_step_above is wrong {where}\nHint: {hint}")
    print(f"check_first_step_above: {len(cases)} curves agree (including step 1, never, ties and dips)")
    return True


@compares_with(_area_reference)
def check_area_under_curve(area_under_curve, n_random: int = 100, seed: int = 0) -> bool:
    """``area_under_curve(records, key)`` returns the area under ``record[key]`` plotted against the step
    (the number of measurements), by the trapezoidal rule: sum over consecutive steps of
    (y_i + y_{i+1}) / 2 * (step_{i+1} - step_i)."""
    rng = np.random.default_rng(seed)
    cases = _curve_cases(rng, n_random)
    for records, key, _ in cases:
        got = _call(area_under_curve, [dict(r) for r in records], key)
        if got is None:
            raise AssertionError("area_under_curve returned None: fill in the function body (it still looks like the stub)")
        got = float(np.asarray(got).reshape(()))
        want = _area_reference(records, key)
        if abs(got - want) <= 1e-9 * max(1.0, abs(want)):
            continue
        y = np.array([r[key] for r in records], float)
        if abs(got - y.sum()) < 1e-9 * max(1.0, abs(want)):
            hint = "you summed the values (rectangles of width 1, one too many): use trapezoids between consecutive steps"
        elif abs(got - y[:-1].sum()) < 1e-9 * max(1.0, abs(want)) or abs(got - y[1:].sum()) < 1e-9 * max(1.0, abs(want)):
            hint = "left/right rectangles: use trapezoids, (y_i + y_{i+1}) / 2 per step interval"
        elif abs(got - y.mean()) < 1e-9 * max(1.0, abs(want)):
            hint = "that is the mean value, not the area: sum the trapezoids between consecutive steps"
        else:
            hint = ("check two records by hand: the area of one trapezoid between consecutive steps, then steps that are not "
                    "1 apart")
        raise AssertionError(f"area_under_curve is wrong for {key} over {len(records)} steps: got {got:.6f}, "
                             f"expected {want:.6f}\nHint: {hint}")
    print(f"check_area_under_curve: {len(cases)} curves agree")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: the mission loop (Sec. III, Fig. 2): plan, move and measure, update the map, evaluate
# --------------------------------------------------------------------------------------------------
class _Log(list):
    """The calls the stand-ins below receive, in order: ("measure", view, step), ("integrate", step), ("evaluate",
    integrations so far), ("plan", visited views)."""


class _SpyEvaluator:
    def __init__(self, log, spy_map):
        self.log, self.map = log, spy_map

    def evaluate(self, reconstruction):
        if reconstruction is not self.map:
            raise AssertionError("world.evaluator.evaluate was given something other than the map: pass it the map")
        n = self.map.integrations
        self.log.append(("evaluate", n))
        return {"psnr": 10.0 + 1.5 * n, "f1": 0.05 * n, "precision": 0.0, "completeness": 0.0}


class _SpyWorld:
    def __init__(self, log, spy_map, targets):
        self.log, self.targets, self.evaluator = log, targets, _SpyEvaluator(log, spy_map)

    def measure(self, view, step):
        self.log.append(("measure", tuple(np.round(np.asarray(view, float), 9)), int(step)))
        return ("measurement", int(step))


class _SpyMap:
    planning_source = object()  # what a planner reads of this map

    def __init__(self, log):
        self.log, self.integrations = log, 0

    def integrate(self, measurement):
        if not (isinstance(measurement, tuple) and measurement[:1] == ("measurement",)):
            raise AssertionError("reconstruction.integrate was given something other than world.measure's measurement")
        self.integrations += 1
        self.log.append(("integrate", measurement[1]))
        return []


class _SpyPlanner:
    def __init__(self, log, views):
        self.log, self.views = log, list(views)

    def next_view(self, source, visited, targets):
        from ..planners import Decision

        if source is not _SpyMap.planning_source:
            raise AssertionError("planner.next_view was not given what the planner reads: pass "
                                 "reconstruction.planning_source (the trained field), not the map or the world")
        self.log.append(("plan", tuple(tuple(np.round(np.asarray(v, float), 9)) for v in np.asarray(visited).reshape(-1, 2))))
        return Decision(view=np.array(self.views.pop(0)))


def _mission_reference(world, reconstruction, planner, budget):
    from ..geometry import TOP_VIEW

    visited, records = [], []
    for step in range(1, budget + 1):
        if step == 1:
            view = np.array(TOP_VIEW)
        else:
            view = planner.next_view(reconstruction.planning_source, np.array(visited), world.targets).view
        reconstruction.integrate(world.measure(view, step))
        result = world.evaluator.evaluate(reconstruction)
        visited.append(np.asarray(view, float))
        records.append({"step": step, "view_rad": [float(v) for v in view], "psnr": result["psnr"], "f1": result["f1"]})
    return records


def _run_with_spies(run_mission, budget, views, targets=(1,)):
    log = _Log()
    spy_map = _SpyMap(log)
    records = _call(run_mission, _SpyWorld(log, spy_map, targets), spy_map, _SpyPlanner(log, views), budget)
    return log, records


def _mission_hint(log, want) -> str:
    kinds, want_kinds = [e[0] for e in log], [e[0] for e in want]
    measures = [e for e in log if e[0] == "measure"]
    want_measures = [e for e in want if e[0] == "measure"]
    if not measures or measures[0][1] != want_measures[0][1]:
        return "every mission starts with the top view (geometry.TOP_VIEW), measured without planning"
    if len(measures) != len(want_measures):
        return (f"the budget counts measurements, the top view included: {len(want_measures)} measurements, so "
                f"{len(want_measures) - 1} planned views (you made {len(measures)})")
    if [e[2] for e in measures] != [e[2] for e in want_measures]:
        return "steps are numbered from 1 (the top view) to the budget, and world.measure(view, step) takes that number"
    if "evaluate" in kinds and kinds.index("evaluate") < kinds.index("integrate"):
        return "evaluate the map after it has integrated the step's measurement (it scores what the map knows now)"
    if kinds.count("evaluate") != want_kinds.count("evaluate"):
        return "evaluate the map once per step, after integrating that step's measurement"
    plans = [e for e in log if e[0] == "plan"]
    want_plans = [e for e in want if e[0] == "plan"]
    if plans != want_plans:
        return ("the planner must see every view measured so far, in order (the top view first), so that it never "
                "returns one of them: append each view to `visited` after measuring it")
    return "each step: plan (from step 2 on), measure, integrate, evaluate, and record step, view_rad, psnr and f1"


@compares_with(_mission_reference)
def check_mission_loop(run_mission, seed: int = 0) -> bool:
    """``run_mission(world, reconstruction, planner, budget)`` runs one mission of ``budget`` measurements: the top view
    first, then planned views (``planner.next_view(reconstruction.planning_source, visited, world.targets).view``),
    each measured (``world.measure(view, step)``), integrated (``reconstruction.integrate``) and evaluated
    (``world.evaluator.evaluate(reconstruction)``); it returns one record per step with ``step``, ``view_rad``,
    ``psnr`` and ``f1``. The checker runs it on stand-ins that log every call."""
    rng = np.random.default_rng(seed)
    for budget in (1, 2, 5):
        views = [(float(rng.uniform(0.1, 1.4)), float(rng.uniform(0.0, 6.2))) for _ in range(budget - 1)]
        log, records = _run_with_spies(run_mission, budget, views + [(0.5, 0.5)] * 3)
        want_log, want_records = _run_with_spies(_mission_reference, budget, views)
        if list(log) != list(want_log):
            raise AssertionError(f"with a budget of {budget}, your loop's calls differ from a mission's.\nyours:    "
                                 f"{[e[0] for e in log]}\nexpected: {[e[0] for e in want_log]}\n"
                                 f"Hint: {_mission_hint(log, want_log)}")
        if not isinstance(records, list) or len(records) != budget:
            raise AssertionError(f"run_mission should return a list of one record per measurement ({budget}), got "
                                 f"{type(records).__name__} of length {len(records) if hasattr(records, '__len__') else '?'}")
        for got, want in zip(records, want_records):
            missing = [k for k in want if k not in got]
            if missing:
                raise AssertionError(f"record {want['step']} lacks {missing}: record step, view_rad, psnr and f1")
            if got["step"] != want["step"] or not np.allclose(got["view_rad"], want["view_rad"]) or \
                    not np.isclose(got["psnr"], want["psnr"]) or not np.isclose(got["f1"], want["f1"]):
                raise AssertionError(f"record {want['step']} is {got}, expected {want}: each record holds the step, the "
                                     "view measured at it and the evaluation of the map after integrating it")
    print("check_mission_loop: budgets 1, 2 and 5 call measure, integrate, evaluate and plan as a mission does")
    return True
