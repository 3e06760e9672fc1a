import json
from dataclasses import replace

import numpy as np
import pytest

from stair_lite.classes import class_id, target_ids
from stair_lite.scenes import (
    AMBIENT,
    DIFFUSE,
    LIGHT_DIRECTION,
    ObjectSpec,
    SceneSpec,
    build_scene,
    list_scenes,
    load_scene,
    load_scene_spec,
    random_scene_spec,
    save_scene_spec,
    spec_from_json,
    surface_albedo,
)

PAPER_TARGETS = {"scene1": ["car"], "scene2": ["camera"], "scene3": ["sofa"], "scene4": ["car", "airplane"]}


def test_shipped_scenes_follow_the_paper():
    assert {"scene1", "scene2", "scene3", "scene4", "ablation_two_chairs"} <= set(list_scenes())
    for name, targets in PAPER_TARGETS.items():
        scene = load_scene(name)
        assert scene.targets == target_ids(targets)
        assert len(scene.object_meshes) >= 5
        assert len(scene.classes_present) >= 3
        for obj in scene.spec.objects:
            assert np.hypot(*obj.position) <= 1.0
        for mesh in scene.object_meshes:
            assert mesh.bounds[0][2] == pytest.approx(0.0, abs=1e-6)  # stands on the ground
            assert np.all(np.abs(mesh.bounds) <= 1.5)


def test_ablation_scene_hides_one_chair_from_the_top_view():
    from stair_lite.geometry import Intrinsics, view_to_pose
    from stair_lite.simulator import Simulator

    scene = load_scene("ablation_two_chairs")
    assert scene.targets == (class_id("chair"),)
    chairs = [m for m, c in zip(scene.object_meshes, scene.object_classes) if c == class_id("chair")]
    assert len(chairs) == 2
    sim = Simulator(scene, Intrinsics.from_fov(200, 200))
    top = sim.render(view_to_pose(np.pi / 2, 0.0))
    from stair_lite.measurement import back_project

    points, _, labels = back_project(top)
    seen = points[labels == class_id("chair")]

    def seen_near(mesh):
        lo, hi = mesh.bounds
        return np.sum(np.all((seen >= lo - 0.01) & (seen <= hi + 0.01), axis=1))

    counts = sorted(seen_near(m) for m in chairs)
    assert counts[0] == 0 and counts[1] > 100  # one chair hidden from above, the other in view
    side = sim.render(view_to_pose(0.12, np.radians(190)))
    points, _, labels = back_project(side)
    seen = points[labels == class_id("chair")]
    assert min(seen_near(m) for m in chairs) > 20  # a low side view sees both


def test_target_mesh_contains_only_targets():
    scene = load_scene("scene4")
    mesh = scene.target_mesh()
    expected = sum(len(m.faces) for m, c in zip(scene.object_meshes, scene.object_classes) if c in scene.targets)
    assert len(mesh.faces) == expected


def test_scene_json_round_trip(tmp_path):
    spec = load_scene_spec("scene2")
    path = save_scene_spec(spec, tmp_path / "copy.json")
    assert load_scene_spec(path) == spec


def test_random_scenes_are_seeded_and_valid():
    a = random_scene_spec(3, n_objects=5, targets=["sofa"])
    assert a == random_scene_spec(3, n_objects=5, targets=["sofa"])
    assert a != random_scene_spec(4, n_objects=5, targets=["sofa"])
    scene = build_scene(a)
    assert class_id("sofa") in scene.classes_present
    assert all(np.hypot(*o.position) <= 1.0 for o in a.objects)


def test_unknown_class_name_is_named():
    with pytest.raises(ValueError, match="unknown class name 'bicycle'"):
        spec_from_json({"targets": ["car"], "objects": [{"class": "bicycle", "position": [0, 0]}]})


def test_unknown_target_is_named():
    with pytest.raises(ValueError, match="'boat'"):
        target_ids(["boat"])
    scene = load_scene("scene1")
    with pytest.raises(ValueError, match="do not occur in scene"):
        scene.check_targets(["airplane"])


def test_malformed_json_is_named(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"objects": [')
    with pytest.raises(ValueError, match="not valid JSON"):
        load_scene_spec(bad)
    bad.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0]}]}))
    with pytest.raises(ValueError, match="'position' must be"):
        load_scene_spec(bad)
    bad.write_text(json.dumps({"targets": ["car"]}))
    with pytest.raises(ValueError, match="missing field 'objects'"):
        load_scene_spec(bad)


def test_missing_scene_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.json"):
        load_scene_spec(tmp_path / "nowhere.json")
    with pytest.raises(ValueError, match="unknown scene 'scene99'"):
        load_scene_spec("scene99")


def test_missing_mesh_file_is_named(tmp_path):
    spec = SceneSpec("s", (ObjectSpec(cls=1, position=(0.0, 0.0), mesh=str(tmp_path / "gone.obj")),), (1,))
    with pytest.raises(FileNotFoundError, match="gone.obj"):
        build_scene(spec)


def test_object_outside_the_cube_is_named():
    spec = SceneSpec("s", (ObjectSpec(cls=1, position=(1.4, 0.0)),), (1,))
    with pytest.raises(ValueError, match=r"position \[1.4, 0.0\] extends outside the scene cube"):
        build_scene(spec)


def test_overlapping_objects_are_named():
    spec = SceneSpec("s", (ObjectSpec(cls=1, position=(0.0, 0.0)), ObjectSpec(cls=4, position=(0.1, 0.0))), (1,))
    with pytest.raises(ValueError, match=r"objects 0 \(car\) and 1 \(sofa\) overlap"):
        build_scene(spec)


def test_objects_may_stand_under_a_table_without_touching():
    table = ObjectSpec(cls=3, position=(0.0, 0.0), scale=1.5, seed=1)
    chair = ObjectSpec(cls=2, position=(0.0, 0.0), scale=0.9, seed=3)
    build_scene(SceneSpec("s", (table, chair), (2,)))  # no error: nested, not interpenetrating


def test_targets_alone_keeps_exactly_the_target_objects():
    scene = load_scene("scene4")
    alone = scene.targets_alone()
    assert sorted(alone.object_classes) == sorted(c for c in scene.object_classes if c in scene.targets)
    assert np.isclose(alone.target_mesh().area, scene.target_mesh().area) and alone.ground is scene.ground


def test_walled_ablation_scene_shows_its_hidden_chair_from_few_views():
    """The occluded chair of ``ablation_hidden_chair`` is hidden from the top and seen (at least
    MIN_PIXELS of 100 x 100) from 5-25 % of the hemisphere; the other chair from most of it."""
    from stair_lite.claims import HIDDEN_CHAIR, MIN_PIXELS, object_pixels
    from stair_lite.geometry import TOP_VIEW, fibonacci_hemisphere

    name = "ablation_hidden_chair"
    scene = load_scene(name)
    assert scene.targets == (class_id("chair"),) and scene.object_classes[HIDDEN_CHAIR[name]] == class_id("chair")
    views = np.concatenate([[TOP_VIEW], fibonacci_hemisphere(100)])
    hidden = object_pixels(name, HIDDEN_CHAIR[name], views) >= MIN_PIXELS
    other = object_pixels(name, 0, views) >= MIN_PIXELS
    assert not hidden[0] and other[0]
    assert 0.05 < hidden[1:].mean() < 0.25 and other[1:].mean() > 0.6


def face_albedo(mesh) -> np.ndarray:
    """The albedo of each face of a baked mesh: its colour with the shading divided out (to 8-bit precision)."""
    shade = AMBIENT + DIFFUSE * np.clip(mesh.face_normals @ LIGHT_DIRECTION, 0.0, None)
    return mesh.visual.face_colors[:, :3] / 255.0 / shade[:, None]


def albedo_shares(mesh) -> np.ndarray:
    """Surface shares of the distinct albedos of a baked mesh (rounded to 0.1)."""
    _, which = np.unique(np.round(face_albedo(mesh), 1), axis=0, return_inverse=True)
    return np.bincount(which.ravel(), weights=mesh.area_faces) / mesh.area


def test_every_object_has_a_many_coloured_surface():
    """Colour carries information: with patterned albedo, on every object of every shipped scene at least
    three albedo colours each cover a sizeable share of the surface, so the unseen sides cannot be guessed
    from one glimpse; a uniform scene gives each object one albedo."""
    for name in list_scenes():
        spec = load_scene_spec(name)
        for mesh, obj in zip(build_scene(replace(spec, albedo="pattern")).object_meshes, spec.objects):
            shares = albedo_shares(mesh)
            assert np.sum(shares > 0.1) >= 2 and np.sum(shares > 0.03) >= 3, (name, obj.class_name, np.sort(shares)[::-1][:4])
        for mesh in build_scene(replace(spec, albedo="uniform")).object_meshes:
            albedo = face_albedo(mesh)
            assert np.abs(albedo - np.median(albedo, axis=0)).max() < 0.02
    assert build_scene(random_scene_spec(5)).spec.albedo == "pattern"  # new scenes are patterned
    with pytest.raises(ValueError, match="albedo must be one of"):
        spec_from_json({**load_scene_spec("scene1").to_json(), "albedo": "striped"})


def test_albedo_pattern_is_seeded_and_moves_with_its_object():
    spec = replace(load_scene_spec("scene1"), albedo="pattern")
    moved = replace(spec, objects=(replace(spec.objects[0], position=(0.2, 0.4), yaw_deg=spec.objects[0].yaw_deg + 40),))
    first, again = build_scene(spec).object_meshes[0], build_scene(moved).object_meshes[0]
    up = (first.face_normals[:, 2] > 0.99) & (again.face_normals[:, 2] > 0.99)  # same shading: upward faces
    same = np.all(first.visual.face_colors[up] == again.visual.face_colors[up], axis=1)
    assert up.sum() > 10 and same.mean() > 0.98  # (faces whose centre lies on a stripe's edge may flip)
    points = np.random.default_rng(0).uniform(-0.5, 0.5, size=(500, 3))
    assert np.array_equal(surface_albedo(points, (0.5, 0.2, 0.1), 3), surface_albedo(points, (0.5, 0.2, 0.1), 3))
    assert not np.array_equal(surface_albedo(points, (0.5, 0.2, 0.1), 3), surface_albedo(points, (0.5, 0.2, 0.1), 4))


@pytest.mark.parametrize("change, match", [
    ({"position": [True, 0]}, r"'position' x must be a finite number, got True"),
    ({"position": [float("nan"), 0]}, r"'position' x must be a finite number, got nan"),
    ({"yaw_deg": float("inf")}, r"'yaw_deg' must be a finite number, got inf"),
    ({"scale": "big"}, r"'scale' must be a finite number, got 'big'"),
    ({"class": 2.5}, r"'class' 2.5 is not a class"),
    ({"class": None}, r"'class' None is not a class"),
    ({"colour": "red"}, r"'colour' must be three numbers in \[0, 1\], got 'red'"),
    ({"colour": [0.5, "x", 0.1]}, r"'colour' must be a finite number, got 'x'"),
    ({"seed": "abc"}, r"'seed' must be an integer in \[0, 2\^32\), got 'abc'"),
    ({"seed": 1e20}, r"'seed' must be an integer"),
])
def test_a_wrong_field_is_refused_by_name_and_value(change, match):
    data = {"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0], **change}]}
    with pytest.raises(ValueError, match=match):
        spec_from_json(data, source="my.json")


def test_an_object_too_small_to_be_seen_is_refused():
    spec = spec_from_json({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0], "scale": 1e-6}]})
    with pytest.raises(ValueError, match="objects must be at least 0.05 m across"):
        build_scene(spec)


def test_a_binary_scene_file_is_named(tmp_path):
    bad = tmp_path / "binary.json"
    bad.write_bytes(bytes(range(256)))
    with pytest.raises(ValueError, match="binary.json is not valid JSON"):
        load_scene_spec(bad)


def test_each_label_colour_shares_its_objects_hue_and_not_another_class_s():
    """A label image never paints a class in the body colour of another class's objects: each object class's label
    colour is nearest, of all the base colours, to its own objects' (in RGB), and has their hue within 30 degrees
    (near-grey colours, the camera's, have no hue to compare)."""
    import colorsys

    from stair_lite.classes import CLASS_COLOURS, CLASS_NAMES
    from stair_lite.scenes import DEFAULT_COLOURS

    names = [n for n in CLASS_NAMES if n in DEFAULT_COLOURS]
    bases = np.array([DEFAULT_COLOURS[n] for n in names])
    for n in names:
        label = CLASS_COLOURS[CLASS_NAMES.index(n)]
        assert names[int(np.argmin(np.linalg.norm(bases - label, axis=1)))] == n, n
        (h_label, s_label, _), (h_base, s_base, _) = colorsys.rgb_to_hsv(*label), colorsys.rgb_to_hsv(*DEFAULT_COLOURS[n])
        if min(s_label, s_base) > 0.2:
            assert min(abs(h_label - h_base), 1 - abs(h_label - h_base)) * 360 < 30, n
