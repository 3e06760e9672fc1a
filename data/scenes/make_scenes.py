"""Regenerate the shipped scene specs (data/scenes/*.json) from fixed seeds.

Run: .venv/bin/python data/scenes/make_scenes.py
The paper's four scenes in spirit (Sec. IV-A: targets car / camera / sofa / car and airplane; five or
more objects of mixed classes at random poses within 1 m of the origin) and the ablation scene
(Sec. IV-D: two target chairs, one hidden from the top view under a table): ``ablation_two_chairs``
hides it from the top view only; ``ablation_hidden_chair`` walls it in on three sides, so that only
about 12 % of the hemisphere sees it (notebook 06 measures this).
"""
import numpy as np

from stair_lite.scenes import SCENE_DIR, ObjectSpec, SceneSpec, build_scene, place_objects, save_scene_spec

P = "procedural"
# Every object carries seeded many-coloured surfaces (stair_lite.scenes.surface_albedo), so a view of an
# object's unseen side teaches colour that no earlier view predicts (one colour per object: "uniform").
ALBEDO = "pattern"
SCENES = {
    "scene1": (("car",), "Target: car. Two cars (one real low-poly model) among furniture.", 11,
               [("car", P), ("car", "car_flyingcar"), ("chair", P), ("table", P), ("sofa", "sofa_assetcoop"), ("camera", P)]),
    "scene2": (("camera",), "Target: camera. Two small cameras between larger objects.", 22,
               [("camera", P), ("camera", "camera_panda3d"), ("sofa", P), ("table", "table_assetcoop"), ("airplane", P), ("chair", P)]),
    "scene3": (("sofa",), "Target: sofa. A sofa and an armchair among other furniture and a car.", 33,
               [("sofa", P), ("sofa", "armchair_assetcoop"), ("chair", "chair_assetcoop"), ("table", P), ("car", P), ("camera", P)]),
    "scene4": (("car", "airplane"), "Targets: car and airplane.", 44,
               [("car", P), ("airplane", P), ("airplane", P), ("chair", P), ("sofa", P), ("table", "coffeetable_assetcoop"), ("camera", P)]),
}


def ablation_scene() -> SceneSpec:
    """Chair A stands in the open; chair B stands under a large table, hidden from the top view,
    with a sofa and a car beside the table so that only some side views see it."""
    objects = (
        ObjectSpec(cls=2, position=(0.65, 0.45), yaw_deg=200.0, seed=1),  # chair A, visible from above
        ObjectSpec(cls=3, position=(-0.35, -0.25), yaw_deg=10.0, scale=1.5, seed=1),  # large table
        ObjectSpec(cls=2, position=(-0.35, -0.25), yaw_deg=100.0, scale=0.9, seed=3),  # chair B, under the table
        ObjectSpec(cls=4, position=(-0.40, 0.72), yaw_deg=90.0, seed=2),  # sofa
        ObjectSpec(cls=1, position=(0.55, -0.60), yaw_deg=60.0, seed=5),  # car
        ObjectSpec(cls=5, position=(0.45, 0.00), yaw_deg=0.0, seed=6, scale=0.6),  # small airplane
    )
    return SceneSpec("ablation_two_chairs", objects, (2,),
                     "Ablation (paper Sec. IV-D): two target chairs; chair B is under the table, unseen from the top view.",
                     albedo=ALBEDO)


def hidden_chair_scene() -> SceneSpec:
    """Chair B stands under a table walled in by sofas on three sides (north, south, west), as high as
    the sofas reach (0.53 m) below the table top (0.59 m): it shows only through the open east side
    and, from 30-45 deg elevation, over the west sofa. Chair A stands in the open to the south."""
    table_half = (0.456, 0.272)  # the half extents of table seed 1 at scale 1.2, yaw 0
    sofa_half_depth, gap = 0.23, 0.02  # sofa seed 2 at scale 1.3
    wall = round(table_half[1] + sofa_half_depth + gap, 3)
    objects = (
        ObjectSpec(cls=2, position=(0.10, -1.00), yaw_deg=200.0, seed=1),  # chair A, in the open
        ObjectSpec(cls=3, position=(0.0, 0.0), yaw_deg=0.0, scale=1.2, seed=1),  # table
        ObjectSpec(cls=2, position=(0.0, 0.0), yaw_deg=100.0, scale=0.75, seed=3),  # chair B, under the table
        ObjectSpec(cls=4, position=(0.12, wall), yaw_deg=90.0, scale=1.3, seed=2),  # sofa, north
        ObjectSpec(cls=4, position=(0.12, -wall), yaw_deg=270.0, scale=1.3, seed=2),  # sofa, south
        ObjectSpec(cls=4, position=(-round(table_half[0] + sofa_half_depth + gap, 3), 0.0), yaw_deg=0.0, scale=1.3, seed=2),  # sofa, west
    )
    return SceneSpec("ablation_hidden_chair", objects, (2,),
                     "Ablation (paper Sec. IV-D): two target chairs; chair B is under a table walled in by sofas on "
                     "three sides, seen only from some views.", albedo=ALBEDO)


def main():
    for name, (targets, description, seed, items) in SCENES.items():
        objects = place_objects(items, np.random.default_rng(seed), max_radius=1.0)
        spec = SceneSpec(name, objects, tuple(build_scene(SceneSpec(name, objects, (objects[0].cls,))).check_targets(targets)), description,
                         albedo=ALBEDO)
        print("wrote", save_scene_spec(spec, SCENE_DIR / f"{name}.json"))
    for spec in (ablation_scene(), hidden_chair_scene()):
        build_scene(spec)
        print("wrote", save_scene_spec(spec, SCENE_DIR / f"{spec.name}.json"))


if __name__ == "__main__":
    main()
