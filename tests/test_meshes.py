"""Tests of stair_lite.meshes: procedural class meshes, the mesh-file loader and the shipped real meshes."""
import hashlib
import re
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from stair_lite.classes import class_id
from stair_lite.meshes import (
    MESH_DIR,
    REAL_MESHES,
    class_mesh,
    load_mesh_file,
    procedural_mesh,
    real_mesh,
)

CLASSES = ["car", "chair", "table", "sofa", "airplane", "camera"]
SEEDS = range(6)


def assert_in_frame(mesh):
    """Metres, z up, resting on z = 0, bounding box centred on the origin in x/y, inside the scene cube."""
    lo, hi = mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9)
    assert (lo[:2] + hi[:2]) / 2 == pytest.approx([0.0, 0.0], abs=1e-9)
    assert np.all(np.abs(mesh.vertices) <= 1.5)


@pytest.mark.parametrize("cls", CLASSES)
def test_procedural_meshes_are_watertight_class_sized_and_on_the_ground(cls):
    for seed in SEEDS:
        mesh = procedural_mesh(cls, seed)
        assert mesh.is_watertight, (cls, seed)
        assert mesh.body_count == 1, (cls, seed)
        assert len(mesh.faces) < 5000
        assert_in_frame(mesh)
        x, y, z = mesh.extents
        horizontal = max(x, y)
        assert 0.3 <= horizontal <= 1.0, (cls, seed, mesh.extents)
        expected = {  # the class's characteristic dimension and its range in metres
            "car": (x, 0.8, 1.0),  # length; cars point along x
            "chair": (z, 0.45, 0.6),  # height
            "table": (horizontal, 0.6, 0.9),
            "sofa": (y, 0.8, 1.0),  # width; sofas face +x
            "airplane": (y, 0.8, 1.0),  # span; the fuselage is along x
            "camera": (x, 0.3, 0.4),  # body width
        }[cls]
        assert expected[1] <= expected[0] <= expected[2], (cls, seed, mesh.extents)


@pytest.mark.parametrize("cls", CLASSES)
def test_procedural_meshes_are_deterministic_and_vary_with_the_seed(cls):
    a, b = procedural_mesh(cls, 3), procedural_mesh(cls, 3)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    c = procedural_mesh(class_id(cls), 3)  # an id works as well as a name
    assert np.array_equal(a.vertices, c.vertices)
    assert not np.array_equal(a.extents, procedural_mesh(cls, 4).extents)


def test_procedural_meshes_are_identical_in_a_fresh_process():
    def digest(seed):
        return [hashlib.sha256(procedural_mesh(c, seed).vertices.tobytes()).hexdigest() for c in CLASSES]

    code = "from stair_lite.meshes import procedural_mesh as p; import hashlib; " + (
        f"print([hashlib.sha256(p(c, 5).vertices.tobytes()).hexdigest() for c in {CLASSES!r}])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == str(digest(5))


@pytest.mark.parametrize("bad", ["background", 0, "boat", 7, 2.5, None])
def test_procedural_mesh_rejects_non_object_classes(bad):
    with pytest.raises(ValueError, match=re.escape(repr(bad))):
        procedural_mesh(bad, 0)


@pytest.mark.parametrize("name", sorted(REAL_MESHES))
def test_real_meshes_load_at_their_default_size(name):
    entry = REAL_MESHES[name]
    class_id(entry.class_name)  # a known class
    assert entry.up_axis in ("y", "z")
    mesh = real_mesh(name)
    assert len(mesh.faces) > 0
    assert_in_frame(mesh)
    assert max(mesh.extents[:2]) == pytest.approx(entry.size)
    assert 0.1 <= mesh.extents[2] <= 1.0
    assert mesh.visual.kind is None  # no textures or colours: the simulator colours meshes itself


def test_real_meshes_cover_the_main_classes():
    assert {"sofa", "chair", "table", "car", "camera"} <= {m.class_name for m in REAL_MESHES.values()}
    with pytest.raises(ValueError, match="sofa_assetcoop"):
        real_mesh("no_such_mesh")


def test_shipped_files_match_sources_md():
    table = dict(re.findall(r"^\| `([^`]+)` \|.*\| `([0-9a-f]{64})` \|", (MESH_DIR / "SOURCES.md").read_text(), re.M))
    shipped = sorted(p.name for p in MESH_DIR.glob("*.obj"))
    assert shipped == sorted(table) == sorted(m.file for m in REAL_MESHES.values())
    for name, digest in table.items():
        assert hashlib.sha256((MESH_DIR / name).read_bytes()).hexdigest() == digest, name
    assert sum((MESH_DIR / name).stat().st_size for name in shipped) < 1_000_000
    for licence in ("LICENSE-panda3d.txt", "LICENSE-assetcoop.txt"):
        assert "Redistribution and use" in (MESH_DIR / licence).read_text()


@pytest.fixture
def tall_box_y_up(tmp_path):
    """A coloured 0.2 x 0.5 x 0.1 box whose tall side is y, off-centre, saved as PLY."""
    box = trimesh.creation.box(extents=(0.2, 0.5, 0.1))
    box.apply_translation((1.0, 2.0, 3.0))
    box.visual.face_colors = (255, 0, 0, 255)
    path = tmp_path / "box.ply"
    box.export(path)
    return path


def test_load_mesh_file_turns_y_up_to_z_up_and_normalises(tall_box_y_up):
    mesh = load_mesh_file(tall_box_y_up, up_axis="y")
    assert mesh.extents == pytest.approx([0.2, 0.1, 0.5])
    assert_in_frame(mesh)
    assert mesh.visual.kind is None
    assert load_mesh_file(tall_box_y_up).extents == pytest.approx([0.2, 0.5, 0.1])
    scaled = load_mesh_file(tall_box_y_up, up_axis="y", size=0.8)
    assert scaled.extents == pytest.approx([0.8, 0.4, 2.0], rel=1e-5)  # PLY stores float32
    assert scaled.bounds[0] == pytest.approx([-0.4, -0.2, 0.0], abs=1e-6)


def test_load_mesh_file_errors_name_the_problem(tmp_path, tall_box_y_up):
    missing = tmp_path / "missing.obj"
    with pytest.raises(FileNotFoundError, match=re.escape(str(missing))):
        load_mesh_file(missing)
    garbage = tmp_path / "garbage.ply"
    garbage.write_bytes(b"this is not a mesh\x00\x01")
    empty = tmp_path / "empty.obj"
    empty.write_text("")
    for bad in (garbage, empty):
        with pytest.raises(ValueError, match=re.escape(str(bad)) + ".*could not be read as a mesh"):
            load_mesh_file(bad)
    with pytest.raises(ValueError, match="'x'"):
        load_mesh_file(tall_box_y_up, up_axis="x")
    for size in (0, -0.5):
        with pytest.raises(ValueError, match=re.escape(repr(size))):
            load_mesh_file(tall_box_y_up, size=size)


def test_class_mesh_sources(tall_box_y_up):
    assert np.array_equal(class_mesh("car", "procedural", seed=2).vertices, procedural_mesh("car", 2).vertices)
    assert np.array_equal(class_mesh(4, "sofa_assetcoop").vertices, real_mesh("sofa_assetcoop").vertices)
    from_file = class_mesh("camera", str(tall_box_y_up))
    assert 0.3 <= max(from_file.extents[:2]) <= 0.4
    with pytest.raises(ValueError, match="'sofa_assetcoop'"):
        class_mesh("car", "sofa_assetcoop")
    with pytest.raises(FileNotFoundError, match="'no_such_source'"):
        class_mesh("car", "no_such_source")
    with pytest.raises(ValueError, match="'background'"):
        class_mesh("background", "procedural")
