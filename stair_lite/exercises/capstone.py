"""The graded property of the capstone (COURSE.md, "Capstone: design your own utility"; notebook 07): the learner's
planner class plugs in like the shipped ones, so that a mission can run it and the headroom instrument can measure it.

``check_capstone_planner`` builds the class from the smoke preset, hands it a briefly trained field, and checks what
every planner must do: a subclass of ``Planner`` that reads the field or no map; ``utility`` gives one finite score per
view; ``next_view`` returns a ``Decision`` with a view on the hemisphere, never within ``MIN_SEPARATION`` of a visited
one over five planning steps; and the same seed gives the same views whatever numpy's global random state (random
choices come from ``self.rng``). Whether the utility is any good is the write-up's question, measured with the
instrument; this check says only that it can be measured.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..config import get_preset
from ..geometry import TOP_VIEW, fibonacci_hemisphere
from ..planners import MIN_SEPARATION, Decision, Planner, far_enough, planner_class
from .common import call as _call, compares_with

_STEPS = 5  # planning steps checked


@lru_cache(maxsize=1)
def _trained_source(preset):
    """A field of the smoke preset that has learnt the top view of scene 1 for a few iterations (built once: planners
    only read it)."""
    from ..maps import ImplicitMap
    from ..scenes import load_scene
    from ..simulator import Simulator
    from ..geometry import view_to_pose

    implicit = ImplicitMap.from_preset(preset, seed=0)
    implicit.integrate(Simulator(load_scene("scene1")).render(view_to_pose(*TOP_VIEW)))
    return implicit.field, load_scene("scene1").targets


def _views_of(cls, preset, source, targets, seed: int) -> list[np.ndarray]:
    """The views of ``_STEPS`` planning steps from the top view, each added to the visited ones."""
    planner = cls.from_preset(preset, np.random.default_rng(seed))
    visited = [np.array(TOP_VIEW)]
    for step in range(_STEPS):
        decision = _call(planner.next_view, source, np.array(visited), targets)
        if not isinstance(decision, Decision):
            raise AssertionError(f"next_view returned {type(decision).__name__}: return a "
                                 "stair_lite.planners.Decision(view=..., candidates=..., chosen_index=...)")
        view = np.asarray(decision.view, dtype=float)
        if view.shape != (2,) or not np.all(np.isfinite(view)):
            raise AssertionError(f"the view must be (elevation, azimuth) in radians, got {decision.view!r}")
        if not -1e-9 <= view[0] <= np.pi / 2 + 1e-9:
            raise AssertionError(f"planning step {step + 2} returned elevation {view[0]:.3f} rad, off the hemisphere "
                                 "[0, pi/2]: draw candidates on the hemisphere (fibonacci_hemisphere, random_hemisphere)")
        if not far_enough(view[None], np.array(visited))[0]:
            raise AssertionError(f"planning step {step + 2} returned {np.round(view, 3)}, within {np.degrees(MIN_SEPARATION):.1f} "
                                 "deg of a visited view: leave out candidates that are not far_enough(candidates, visited)")
        visited.append(view)
    return visited[1:]


@compares_with(planner_class("max_distance"))  # what the cells after the check use until the learner's planner passes
def check_capstone_planner(learners_planner, seed: int = 0) -> bool:
    """``learners_planner``: the learner's planner class (a subclass of ``stair_lite.planners.Planner``; the docstring of
    this module says what is checked)."""
    if not (isinstance(learners_planner, type) and issubclass(learners_planner, Planner)):
        raise AssertionError(f"{learners_planner!r} is not a subclass of stair_lite.planners.Planner: write "
                             "`class MyPlanner(Planner):` and pass the class itself (not an instance)")
    if learners_planner.reads not in (None, "implicit"):
        raise AssertionError(f"reads = {learners_planner.reads!r}: the headroom instrument measures planners that read "
                             "the field (\"implicit\") or no map (None)")
    preset = get_preset("smoke")
    field, targets = _trained_source(preset)
    source = field if learners_planner.reads == "implicit" else None
    planner = learners_planner.from_preset(preset, np.random.default_rng(seed))
    views = fibonacci_hemisphere(24, azimuth_offset=0.4)
    scores = _call(planner.utility, source, views, np.array([TOP_VIEW]), targets)
    if scores is None:
        raise AssertionError("utility returned None: override utility(source, views, visited, targets) to return one "
                             "score per view (the instrument rank-correlates it with what each view teaches)")
    scores = np.asarray(scores, dtype=float)
    if scores.shape != (len(views),) or not np.all(np.isfinite(scores)):
        raise AssertionError(f"utility must return {len(views)} finite scores for {len(views)} views, got shape "
                             f"{scores.shape}" + ("" if np.all(np.isfinite(scores)) else " with NaN or infinite values"))
    np.random.seed(seed + 1)
    first = _views_of(learners_planner, preset, source, targets, seed)
    np.random.seed(seed + 2)
    again = _views_of(learners_planner, preset, source, targets, seed)
    if not np.allclose(first, again):
        raise AssertionError("the same seed gave other views: draw every random choice from self.rng (seeded by the "
                             "mission), not from np.random or random")
    print(f"check_capstone_planner: {learners_planner.__name__} scores views and plans {_STEPS} steps on the hemisphere, "
          "never near a visited view, the same for the same seed")
    return True
