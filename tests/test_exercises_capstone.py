"""The capstone's graded property accepts planners that plug in and rejects those that cannot be measured."""
import numpy as np
import pytest

from stair_lite.exercises.capstone import check_capstone_planner
from stair_lite.geometry import fibonacci_hemisphere, random_hemisphere
from stair_lite.planners import Decision, Planner, far_enough, planner_class


class Elevation(Planner):
    """The skeleton's placeholder: prefers high views, never near a visited one."""

    reads = "implicit"
    separate = True
    shift = 0.0

    def utility(self, source, views, visited, targets):
        return views[:, 0].astype(float)

    def candidates(self):
        return fibonacci_hemisphere(100, azimuth_offset=self.rng.uniform(0, 2 * np.pi))

    def next_view(self, source, visited, targets):
        candidates = self.candidates()
        scores = self.utility(source, candidates, visited, targets)
        if self.separate:
            scores = np.where(far_enough(candidates, visited), scores, -np.inf)
        best = int(np.argmax(scores))
        return Decision(view=candidates[best] - [self.shift, 0.0], candidates=candidates, chosen_index=best)


def test_accepts_the_skeleton_and_shipped_planners():
    assert check_capstone_planner(Elevation)
    assert check_capstone_planner(planner_class("max_distance"))


class NoSeparation(Elevation):
    separate = False


class GlobalRandom(Elevation):
    def candidates(self):
        return random_hemisphere(100, np.random.default_rng(np.random.randint(1 << 30)))


class BelowGround(Elevation):
    shift = 1.7


class NoUtility(Elevation):
    def utility(self, source, views, visited, targets):
        return super().utility(source, views, visited, targets) if len(views) == 100 else None


class OneScore(Elevation):
    def utility(self, source, views, visited, targets):
        return float(views[:, 0].max()) if len(views) != 100 else super().utility(source, views, visited, targets)


class NotDecision(Elevation):
    def next_view(self, source, visited, targets):
        return super().next_view(source, visited, targets).view


class ReadsVoxels(Elevation):
    reads = "explicit"


@pytest.mark.parametrize("wrong, hint", [
    (NoSeparation, "within 8.1 deg of a visited view"),
    (GlobalRandom, "self.rng"),
    (BelowGround, "off the hemisphere"),
    (NoUtility, "returned None"),
    (OneScore, "24 finite scores"),
    (NotDecision, "Decision"),
    (ReadsVoxels, "measures planners that read"),
])
def test_rejects_planners_that_cannot_be_measured(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_capstone_planner(wrong)


def test_rejects_an_instance_and_a_function():
    with pytest.raises(AssertionError, match="not a subclass"):
        check_capstone_planner(lambda source, visited, targets: None)
