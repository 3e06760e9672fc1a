"""What the background's tie rule (``utility.ray_classes``) changes on this CPU, on a stored mission's state: how many of a
planning step's candidate rays the plain argmax of the rendered classes gives another class than the rule, and the
mission's next view under each (with its own planner state, then with another draw of candidates, ``--seed``).

On an Intel Xeon the classes' equal shares of a ray through the marked unknown come out equal and nothing changes; on an
AMD EPYC their last bits differ and the plain argmax makes some such rays the target (RESULTS.md, "At the paper's scale").

Run: .venv/bin/python benchmarks/class_tie.py FOLDER [--seed 5]
(FOLDER: a mission's results folder with its checkpoint, copied first; the stored one is not changed.)
"""
import argparse
import json
import os
import shutil
import tempfile

import numpy as np
import torch

from stair_lite import utility
from stair_lite.mission import Mission, MissionConfig
from stair_lite.planners import make_planner
from stair_lite.results_folder import METRICS_FILE

RULE = utility.ray_classes  # the rule itself, kept while a run swaps the module's in and out


def plain_argmax(counts: dict):
    """The rule before: the plain argmax, counting the rays where it differs from ``ray_classes``."""
    def classes(sem):
        plain, rule = sem.argmax(dim=-1), RULE(sem)
        counts["rays"] += plain.numel()
        counts["differ"] += int((plain != rule).sum())
        return plain
    return classes


def next_view(folder: str, scratch: str, classes, seed: int | None):
    """The next view of the mission stored in ``folder`` with ``classes`` as the rays' class rule: its own planner's
    (``seed`` None) or a fresh planner's of that seed."""
    stored = json.load(open(os.path.join(folder, METRICS_FILE)))
    config = stored["config"]
    copy = shutil.copytree(folder, os.path.join(scratch, "state"), dirs_exist_ok=True)
    mission = Mission(MissionConfig(scene=config["scene"], planner=config["planner"], seed=config["seed"],
                                    preset=config["preset"], budget=len(stored["steps"])), out=copy, resume=True)
    utility.ray_classes = classes
    try:
        if seed is None:
            return mission.plan().view
        planner = make_planner(config["planner"], mission.preset, seed=seed)
        return planner.next_view(mission.map.field, np.array(mission.visited), mission.targets).view
    finally:
        utility.ray_classes = RULE


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("folder")
    parser.add_argument("--seed", type=int, default=5, help="the other draw of candidates")
    args = parser.parse_args()
    torch.set_num_threads(1)  # as sweeps plan
    with tempfile.TemporaryDirectory() as scratch:
        for seed in (None, args.seed):
            counts = {"rays": 0, "differ": 0}
            plain = next_view(args.folder, scratch, plain_argmax(counts), seed)
            rule = next_view(args.folder, scratch, RULE, seed)
            label = "the mission's own planner" if seed is None else f"a planner of seed {seed}"
            print(f"{label}: {counts['differ']} of {counts['rays']} candidate rays of another class under the plain "
                  f"argmax; next view (el, az) [deg] plain {np.round(np.degrees(plain), 2)}, with the rule "
                  f"{np.round(np.degrees(rule), 2)}: {'the same' if np.allclose(plain, rule) else 'different'}")


if __name__ == "__main__":
    main()
