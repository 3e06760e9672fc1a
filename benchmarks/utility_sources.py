"""Where a candidate view's utility comes from, on the state of a stored mission (a results folder with its checkpoint,
e.g. one of the paper-scale comparison's on the machine that ran it: checkpoints are not committed).

First the share of the cube's lattice vertices that no measured ray reached, by distance from the cube's centre. Then
the mission's planner (its variant, its seed) scores its candidates on the restored map; for its best-rated allowed
candidates and for a few views spread around the scene, the planning render of Eqs. 10-14 is taken apart ray by ray:
how many rays the target mask keeps, U_et and U_er, the share of U_et from lattice vertices the planning snapshot marks
unknown (no measured ray reached them: they carry the prior occupancy ``unknown_occupancy``), the share of U_et from
samples within ``--near`` metres of the candidate camera (and that of U_er), and the transmittance where the target rays first meet an
unknown vertex. With ``--unknown-within R``, also where the planner's best next views go when only the unreached vertices
within R metres of the cube's centre are marked (``UtilityOptions.unknown_within``; ``stair_volume`` marks the ball
inscribed in the cube, R = 1.5). (RESULTS.md, "A lead, from seed 0 alone".)

Run: .venv/bin/python benchmarks/utility_sources.py --mission FOLDER [--best 2] [--near 0.5] [--elevation 30]
     [--unknown-within 1.5]
"""
import argparse
import dataclasses
import inspect
import tempfile
from pathlib import Path

import numpy as np
import torch

import stair_lite  # noqa: F401
from bench_evaluation import stored_mission
from stair_lite.classes import BACKGROUND, NUM_CLASSES
from stair_lite.geometry import pixel_rays, view_to_pose
from stair_lite.planners import far_enough, make_planner
from stair_lite.rendering import compositing_weights, ray_box_intersection, sample_along_rays
from stair_lite.utility import FieldSnapshot, render_uncertainty, score_views

# the candidate renders' near plane, as the planner's scores take it
NEAR = inspect.signature(render_uncertainty).parameters["near"].default


@torch.no_grad()
def sources(snapshot: FieldSnapshot, intrinsics, view, n_samples: int, targets, unknown: torch.Tensor, near: float,
            min_distance: float) -> dict:
    """The planning render of one view (as ``utility.render_uncertainty`` takes it, without options) taken apart."""
    origins, dirs = (torch.as_tensor(a, dtype=torch.float32) for a in pixel_rays(intrinsics, view_to_pose(*view)))
    t_near, t_far, hit = ray_box_intersection(origins, dirs, snapshot.lattice.bound, min_distance)
    t = sample_along_rays(t_near, torch.where(hit, t_far, t_near + 1e-3), n_samples)
    vertex = snapshot.lattice.nearest_index_on_rays(origins, dirs, t)
    values = snapshot.lookup_on_rays(origins, dirs, t)
    occ, entropy, probs = values[..., 0] * hit[:, None], values[..., 1] * hit[:, None], values[..., 2 : 2 + NUM_CLASSES]
    weights, transmittance = compositing_weights(occ)
    sem = torch.bmm(weights[:, None, :], probs).squeeze(1)
    sem[:, BACKGROUND] += 1.0 - weights.sum(dim=1)
    target = torch.isin(sem.argmax(dim=1), torch.as_tensor(targets))
    part = transmittance * entropy  # each sample's share of H_ray (Eq. 11)
    is_unknown = unknown[vertex] & hit[:, None]
    distance = t * dirs.norm(dim=1, keepdim=True)  # from the camera
    u_et = part[target].sum()
    first = is_unknown.float().argmax(dim=1)
    meets = target & is_unknown.any(dim=1)
    return {"target rays": int(target.sum()), "U_et": float(u_et), "U_er": float(part.sum()),
            "unknown share": float(part[target][is_unknown[target]].sum() / u_et) if u_et > 0 else 0.0,
            "near-camera share": float(part[target][distance[target] <= near].sum() / u_et) if u_et > 0 else 0.0,
            "U_er near-camera share": float(part[distance <= near].sum() / part.sum()) if part.sum() > 0 else 0.0,
            "meet unknown": int(meets.sum()),
            "T at the unknown": float(transmittance[meets, first[meets]].median()) if meets.any() else float("nan")}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mission", required=True, help="a mission's results folder with its checkpoint")
    parser.add_argument("--best", type=int, default=2, help="how many of the planner's best-rated candidates to take apart")
    parser.add_argument("--near", type=float, default=0.5, help="[m] the distance from the camera counted as near it")
    parser.add_argument("--elevation", type=float, default=30.0, help="[deg] of the spread views (every 60 deg of azimuth)")
    parser.add_argument("--unknown-within", type=float, default=None, help="[m] also score the candidates with the "
                        "unknown marked only within this distance of the cube's centre")
    args = parser.parse_args()
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as copy_to:
        mission = stored_mission(Path(args.mission), Path(copy_to))
        field, targets = mission.map.field, mission.targets
        visited = np.array([r["view_rad"] for r in mission.records])
        planner = make_planner(mission.config.planner, mission.preset, seed=mission.config.seed + 1)
        decision = planner.next_view(field, visited, targets)
        options, plan = planner.options, mission.preset.plan
        snapshot = FieldSnapshot.for_planning(field, options, targets)
        unknown = ~field.reached if options.unknown_occupancy > 0 else torch.zeros_like(field.reached)
        allowed = far_enough(decision.candidates, visited)
        points = snapshot.lattice.points()
        radius, above = points.norm(dim=1), points[:, 2] > 0.05
        shells = [(0.0, 1.0), (1.0, 1.5), (1.5, 1.8), (1.8, 2.7)]
        print("unreached share of the vertices above the ground, by distance from the cube's centre: " + ", ".join(
            f"{lo}-{hi} m {float(unknown[(radius >= lo) & (radius < hi) & above].float().mean()):.0%}" for lo, hi in shells))
        ranked = [i for i in np.argsort(-decision.scores.utility) if allowed[i]][: args.best]
        spread = [np.radians([args.elevation, az]) for az in range(0, 360, 60)]
        print(f"{args.mission} after {len(visited)} views; visited (el, az) [deg]: "
              f"{[tuple(np.degrees(v).round().astype(int).tolist()) for v in visited]}")
        print(f"planner {mission.config.planner}: unknown occupancy {options.unknown_occupancy}, near plane "
              f"{NEAR} m, {planner.intrinsics.width}x{planner.intrinsics.height} rays x "
              f"{plan.candidate_samples} samples per candidate")
        for k, i in enumerate(ranked):  # the render taken apart gives the planner's own U_et
            own = sources(snapshot, planner.intrinsics, decision.candidates[i], plan.candidate_samples, targets, unknown,
                          args.near, NEAR)["U_et"]
            assert np.isclose(own, decision.scores.exploitation[i], rtol=1e-4), (own, decision.scores.exploitation[i])
        for label, view in [(f"best #{k + 1}", decision.candidates[i]) for k, i in enumerate(ranked)] + \
                           [("spread", v) for v in spread]:
            s = sources(snapshot, planner.intrinsics, view, plan.candidate_samples, targets, unknown, args.near, NEAR)
            el, az = np.degrees(view)
            print(f"{label:8s} el {el:5.1f} az {az:6.1f}: {s['target rays']:5d} target rays, U_et {s['U_et']:8.1f}, "
                  f"U_er {s['U_er']:8.1f}; of U_et {s['unknown share']:.0%} from unknown vertices, "
                  f"{s['near-camera share']:.0%} within {args.near} m of the camera (of U_er {s['U_er near-camera share']:.0%}); "
                  f"{s['meet unknown']} target rays meet the unknown, at transmittance {s['T at the unknown']:.2f} (median)")
        if args.unknown_within is not None:
            within = dataclasses.replace(options, unknown_within=args.unknown_within)
            scores = score_views(FieldSnapshot.for_planning(field, within, targets), decision.candidates, targets,
                                 planner.intrinsics, plan.candidate_samples, within)
            best = [i for i in np.argsort(-scores.utility) if allowed[i]][:5]
            print(f"with the unknown marked only within {args.unknown_within} m of the cube's centre, the five best next "
                  f"views (el, az) [deg]: {[tuple(np.degrees(decision.candidates[i]).round().astype(int).tolist()) for i in best]}")

if __name__ == "__main__":
    main()
