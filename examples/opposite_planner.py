"""A researcher's own planner, in its own file: no edit of the package, no registration.

Run it like a shipped planner, naming the file and the class:

    python -m stair_lite run --planner examples/opposite_planner.py:OppositePlanner --out runs/opposite
    python -m stair_lite sweep --planners stair,examples/opposite_planner.py:OppositePlanner --seeds 2 --out runs/mine

A planner subclasses ``stair_lite.planners.Planner`` and overrides ``next_view(source, visited, targets)``: ``source``
is what it reads of the map (``reads``: None here, so nothing; "implicit" gives the trained ``SemanticField``),
``visited`` the (elevation, azimuth) views so far in radians, ``targets`` the target class ids. It returns a
``Decision``; its random choices use ``self.rng`` (seeded by the mission, stored in its checkpoint). A mission records
the file's content hash, so a mission or sweep resumed after the file changed is refused.
"""
import numpy as np

from stair_lite.geometry import random_hemisphere
from stair_lite.planners import Decision, Planner, far_enough


class OppositePlanner(Planner):
    """Map-free: of 64 random views, the one whose azimuth lies farthest from the last view's (views too close to a
    visited one are never chosen)."""

    def next_view(self, source, visited, targets) -> Decision:
        candidates = random_hemisphere(64, self.rng)
        azimuth_gap = np.abs(np.angle(np.exp(1j * (candidates[:, 1] - visited[-1][1]))))
        score = np.where(far_enough(candidates, visited), azimuth_gap, -np.inf)
        best = int(np.argmax(score))
        return Decision(view=candidates[best], candidates=candidates, chosen_index=best)
