"""Class meshes for the scenes: seeded procedural ones and a few real third-party ones.

Introduced in notebook 01. The paper uses ShapeNet models, which cannot be downloaded here, so a
scene object comes from one of two sources:

* ``procedural_mesh(cls, seed)`` builds a class object (car, chair, table, sofa, airplane, camera)
  from simple primitives whose sizes and proportions are drawn from a seeded random generator, and
  unions them into one watertight surface (clean ground truth for the mesh metrics).
* ``real_mesh(name)`` loads one of the small real meshes shipped in ``data/meshes`` (converted once
  from Panda3D packages, see ``data/meshes/SOURCES.md``); most of them are not watertight.

Every mesh comes out in the same frame: metres, z up, resting on z = 0, its bounding box centred on
the origin in x and y.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from pathlib import Path

import numpy as np
import trimesh

from .classes import CLASS_NAMES, class_id

MESH_DIR = Path(__file__).resolve().parent.parent / "data" / "meshes"


@dataclass(frozen=True)
class RealMesh:
    """A real mesh shipped in ``MESH_DIR``: its file, class, up axis, default size and licence."""

    file: str
    class_name: str
    up_axis: str
    size: float  # default longest horizontal (x/y) extent in metres
    licence: str


_ASSETCOOP = "Panda3D licence (Modified BSD)"
_PANDA3D = "Modified BSD"

REAL_MESHES: dict[str, RealMesh] = {
    "sofa_assetcoop": RealMesh("sofa_assetcoop.obj", "sofa", "z", 0.9, _ASSETCOOP),
    "armchair_assetcoop": RealMesh("armchair_assetcoop.obj", "sofa", "z", 0.55, _ASSETCOOP),
    "chair_assetcoop": RealMesh("chair_assetcoop.obj", "chair", "z", 0.3, _ASSETCOOP),
    "table_assetcoop": RealMesh("table_assetcoop.obj", "table", "z", 0.8, _ASSETCOOP),
    "coffeetable_assetcoop": RealMesh("coffeetable_assetcoop.obj", "table", "z", 0.7, _ASSETCOOP),
    "car_flyingcar": RealMesh("car_flyingcar.obj", "car", "z", 0.9, _ASSETCOOP),
    "camera_panda3d": RealMesh("camera_panda3d.obj", "camera", "z", 0.35, _PANDA3D),
    "teapot_panda3d": RealMesh("teapot_panda3d.obj", "background", "z", 0.4, _PANDA3D),
}

# Longest horizontal extent (metres) given to a mesh file loaded for a class by ``class_mesh``.
_CLASS_SIZE = {"car": 0.9, "chair": 0.35, "table": 0.75, "sofa": 0.9, "airplane": 0.9, "camera": 0.35}


# ---------------------------------------------------------------------------------------------
# Normalisation and loading
# ---------------------------------------------------------------------------------------------


def _normalise(mesh: trimesh.Trimesh, size: float | None = None) -> trimesh.Trimesh:
    """Scale so the longest x/y extent is ``size`` (if given), centre x/y on the origin, rest on z = 0."""
    if size is not None:
        mesh.apply_scale(size / np.ptp(mesh.vertices[:, :2], axis=0).max())
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    return mesh


def load_mesh_file(path: str | Path, up_axis: str = "z", size: float | None = None) -> trimesh.Trimesh:
    """Load an OBJ/PLY/STL/GLB file as one plain mesh in the stair_lite frame.

    Visuals are dropped, a y-up mesh is turned z-up, and the result is centred on the origin in x/y
    and rests on z = 0. With ``size``, it is scaled so its longest horizontal extent is ``size`` metres.
    """
    path = Path(path)
    if up_axis not in ("y", "z"):
        raise ValueError(f"up_axis must be 'y' or 'z', got {up_axis!r}")
    if size is not None and not size > 0:
        raise ValueError(f"size must be a positive length in metres, got {size!r}")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    try:
        loaded = trimesh.load(path, force="mesh")
    except Exception as err:
        raise ValueError(f"{path} could not be read as a mesh: {err}") from err
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{path} could not be read as a mesh: it holds no triangles")
    mesh = trimesh.Trimesh(loaded.vertices, loaded.faces)  # geometry only: no textures or materials
    if up_axis == "y":  # rotate +90 degrees about x: (x, y, z) -> (x, -z, y)
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    if size is not None and np.ptp(mesh.vertices[:, :2], axis=0).max() == 0:
        raise ValueError(f"cannot scale {path} to size {size!r}: it has no horizontal extent")
    return _normalise(mesh, size)


def real_mesh(name: str) -> trimesh.Trimesh:
    """Load the shipped real mesh ``name`` (a key of ``REAL_MESHES``) at its default size."""
    if name not in REAL_MESHES:
        raise ValueError(f"unknown real mesh {name!r}; known: {', '.join(REAL_MESHES)}")
    entry = REAL_MESHES[name]
    return load_mesh_file(MESH_DIR / entry.file, up_axis=entry.up_axis, size=entry.size)


def class_mesh(cls: str | int, source: str, seed: int = 0) -> trimesh.Trimesh:
    """A mesh of class ``cls`` from ``source``: "procedural", a ``REAL_MESHES`` name, or a mesh file path."""
    name = _object_class_name(cls)
    if source == "procedural":
        return procedural_mesh(name, seed)
    if source in REAL_MESHES:
        if REAL_MESHES[source].class_name != name:
            raise ValueError(f"real mesh {source!r} is a {REAL_MESHES[source].class_name}, not a {name}")
        return real_mesh(source)
    if not Path(source).is_file():
        raise FileNotFoundError(
            f"mesh source {source!r} is neither 'procedural', a real mesh name "
            f"({', '.join(REAL_MESHES)}) nor an existing mesh file"
        )
    return load_mesh_file(source, size=_CLASS_SIZE[name])


# ---------------------------------------------------------------------------------------------
# Procedural class meshes
# ---------------------------------------------------------------------------------------------


def _box(extents, centre, angle: float = 0.0) -> trimesh.Trimesh:
    """An axis-aligned box of ``extents`` at ``centre``, optionally turned by ``angle`` about z."""
    transform = trimesh.transformations.rotation_matrix(angle, [0, 0, 1])
    transform[:3, 3] = centre
    return trimesh.creation.box(extents=extents, transform=transform)


def _cylinder(radius: float, length: float, centre, axis: str = "z", sections: int = 32) -> trimesh.Trimesh:
    """A cylinder along ``axis`` ("x", "y" or "z") centred at ``centre``."""
    mesh = trimesh.creation.cylinder(radius=radius, height=length, sections=sections)
    if axis != "z":
        turn_about = [0, 1, 0] if axis == "x" else [1, 0, 0]
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, turn_about))
    mesh.apply_translation(centre)
    return mesh


def _span(centre: float, extent: float) -> tuple[float, float]:
    """The interval of length ``extent`` around ``centre``."""
    return centre - extent / 2, centre + extent / 2


def _hull(*slabs) -> trimesh.Trimesh:
    """Convex hull of the corners of boxes given as ((x0, x1), (y0, y1), (z0, z1)): tapered parts."""
    points = [corner for slab in slabs for corner in product(*slab)]
    return trimesh.convex.convex_hull(np.array(points, dtype=np.float64))


def _car(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """Body box, tapered cabin, four wheels; the car points along +x."""
    length = rng.uniform(0.8, 1.0)
    width = length * rng.uniform(0.40, 0.48)
    wheel_r = length * rng.uniform(0.09, 0.11)
    wheel_w = rng.uniform(0.06, 0.08)
    clearance = wheel_r * rng.uniform(0.5, 0.7)
    body_h = length * rng.uniform(0.14, 0.18)
    top = clearance + body_h
    cabin_len = length * rng.uniform(0.45, 0.65)  # long cabins make estates and vans
    roof_len = cabin_len * rng.uniform(0.55, 0.8)
    cabin_h = length * rng.uniform(0.12, 0.17)
    cabin_x = length * rng.uniform(-0.12, 0.0)  # cabins sit towards the rear
    parts = [
        _box((length, width, body_h), (0, 0, clearance + body_h / 2)),
        _hull(
            (_span(cabin_x, cabin_len), _span(0, 0.9 * width), (top - 0.01,) * 2),
            (_span(cabin_x, roof_len), _span(0, 0.76 * width), (top + cabin_h,) * 2),
        ),
    ]
    wheel_x = length / 2 - length * rng.uniform(0.16, 0.2)
    wheel_y = width / 2 - 0.3 * wheel_w
    for sx, sy in product((-1, 1), (-1, 1)):
        parts.append(_cylinder(wheel_r, wheel_w, (sx * wheel_x, sy * wheel_y, wheel_r), axis="y"))
    return parts


def _chair(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """Seat, back, four legs or a swivel base, optional arms; the chair faces +x."""
    height = rng.uniform(0.48, 0.6)
    seat_top = height * rng.uniform(0.45, 0.55)
    width = height * rng.uniform(0.62, 0.72)
    depth = width * rng.uniform(0.9, 1.1)
    seat_t = rng.uniform(0.03, 0.045)
    back_t = rng.uniform(0.03, 0.045)
    back_h = height - seat_top + seat_t  # the back reaches down to the seat's underside
    parts = [
        _box((depth, width, seat_t), (0, 0, seat_top - seat_t / 2)),
        _box((back_t, width, back_h), (back_t / 2 - depth / 2, 0, height - back_h / 2)),
    ]
    if rng.random() < 0.3:  # swivel base: a column on five spokes
        column_h = seat_top - seat_t + 0.01
        spoke = width * rng.uniform(0.4, 0.5)
        parts.append(_cylinder(rng.uniform(0.02, 0.025), column_h, (0, 0, column_h / 2), sections=16))
        for k in range(5):
            angle = 2 * np.pi * k / 5
            centre = (np.cos(angle) * spoke / 2, np.sin(angle) * spoke / 2, 0.015)
            parts.append(_box((spoke, 0.035, 0.03), centre, angle))
    else:  # four legs
        leg = rng.uniform(0.03, 0.04)
        leg_h = seat_top - seat_t + 0.005
        for sx, sy in product((-1, 1), (-1, 1)):
            parts.append(_box((leg, leg, leg_h), (sx * (depth - leg) / 2, sy * (width - leg) / 2, leg_h / 2)))
    if rng.random() < 0.4:  # arms: a rest on a front post at each side
        arm_h = height * rng.uniform(0.12, 0.18)
        arm_w = 0.03
        for sy in (-1, 1):
            y = sy * (width - arm_w) / 2
            parts.append(_box((depth, arm_w, 0.03), (0, y, seat_top + arm_h)))
            post_h = arm_h + 0.01
            parts.append(_box((0.03, arm_w, post_h), (depth / 2 - 0.015, y, seat_top - 0.01 + post_h / 2)))
    return parts


def _table(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """A rectangular top on four legs, or a round top on a pedestal."""
    length = rng.uniform(0.6, 0.9)
    height = rng.uniform(0.35, 0.5)
    top_t = rng.uniform(0.03, 0.05)
    leg_h = height - top_t + 0.005
    if rng.random() < 0.35:  # round top, pedestal and base disc
        return [
            _cylinder(length / 2, top_t, (0, 0, height - top_t / 2), sections=48),
            _cylinder(rng.uniform(0.025, 0.04), leg_h, (0, 0, leg_h / 2), sections=16),
            _cylinder(length * rng.uniform(0.22, 0.3), 0.03, (0, 0, 0.015), sections=32),
        ]
    width = length * rng.uniform(0.5, 0.85)
    leg = rng.uniform(0.035, 0.06)
    inset = rng.uniform(0.0, 0.05)
    parts = [_box((length, width, top_t), (0, 0, height - top_t / 2))]
    leg_x, leg_y = length / 2 - inset - leg / 2, width / 2 - inset - leg / 2
    for sx, sy in product((-1, 1), (-1, 1)):
        parts.append(_box((leg, leg, leg_h), (sx * leg_x, sy * leg_y, leg_h / 2)))
    return parts


def _sofa(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """Seat, back, two arms, on feet or a plinth; the sofa faces +x and is widest along y."""
    width = rng.uniform(0.8, 1.0)
    depth = width * rng.uniform(0.38, 0.48)
    foot_h = rng.uniform(0.03, 0.05) if rng.random() < 0.6 else 0.0
    seat_top = rng.uniform(0.18, 0.24)
    back_top = rng.uniform(0.35, 0.45)
    arm_top = seat_top + rng.uniform(0.06, 0.12)
    arm_w = rng.uniform(0.06, 0.1)
    back_t = rng.uniform(0.07, 0.11)
    parts = [
        _box((depth, width, seat_top - foot_h), (0, 0, (seat_top + foot_h) / 2)),
        _box((back_t, width, back_top - foot_h), (back_t / 2 - depth / 2, 0, (back_top + foot_h) / 2)),
    ]
    for sy in (-1, 1):
        parts.append(_box((depth, arm_w, arm_top - foot_h), (0, sy * (width - arm_w) / 2, (arm_top + foot_h) / 2)))
    if foot_h > 0:
        foot_h += 0.005  # overlap the body so the union is one piece
        for sx, sy in product((-1, 1), (-1, 1)):
            parts.append(_box((0.04, 0.04, foot_h), (sx * (depth / 2 - 0.04), sy * (width / 2 - 0.04), foot_h / 2)))
    return parts


def _airplane(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """Capsule fuselage along x, swept wings, tailplane, fin and 0, 2 or 4 engines; span along y."""
    span = rng.uniform(0.8, 1.0)
    length = span * rng.uniform(0.75, 0.95)
    radius = rng.uniform(0.035, 0.05)
    fuselage = trimesh.creation.capsule(height=length - 2 * radius, radius=radius, count=[16, 16])
    fuselage.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    parts = [fuselage]

    root_chord = length * rng.uniform(0.18, 0.25)
    tip_chord = root_chord * rng.uniform(0.3, 0.5)
    sweep = span * rng.uniform(0.05, 0.2)  # how far back the wing tip's leading edge sits
    wing_le = length * rng.uniform(0.05, 0.15)  # leading edge at the root
    wing_z = radius * (0.5 if rng.random() < 0.3 else -0.5)  # high or low wing
    t = rng.uniform(0.03, 0.04)  # wing thickness
    for sy in (-1, 1):
        parts.append(_hull(
            ((wing_le - root_chord, wing_le), (0, 0), _span(wing_z, t)),
            ((wing_le - sweep - tip_chord, wing_le - sweep), (sy * span / 2,) * 2, _span(wing_z, 0.03)),
        ))

    tail_span = span * rng.uniform(0.3, 0.4)
    tail_chord = root_chord * rng.uniform(0.4, 0.6)
    tail_le = -length / 2 + radius + tail_chord
    for sy in (-1, 1):
        parts.append(_hull(
            ((tail_le - tail_chord, tail_le), (0, 0), _span(0, 0.03)),
            ((tail_le - tail_chord - 0.05, tail_le - 0.05), (sy * tail_span / 2,) * 2, _span(0, 0.03)),
        ))
    fin_h = rng.uniform(0.1, 0.15)
    parts.append(_hull(
        ((tail_le - 1.2 * tail_chord, tail_le), _span(0, 0.03), (0, 0)),
        ((tail_le - 1.2 * tail_chord - 0.05, tail_le - 0.6 * tail_chord - 0.05), _span(0, 0.03), (radius + fin_h,) * 2),
    ))

    engine_r = rng.uniform(0.03, 0.04)
    engine_len = rng.uniform(0.1, 0.14)
    stations = [(), (0.35,), (0.3, 0.6)][rng.integers(3)]  # engines along the half span (fractions)
    for f in stations:
        x = wing_le - sweep * f  # centred on the wing's leading edge
        z = wing_z - t / 2 - 0.6 * engine_r
        for sy in (-1, 1):
            parts.append(_cylinder(engine_r, engine_len, (x, sy * f * span / 2, z), axis="x", sections=20))
    return parts


def _camera(rng: np.random.Generator) -> list[trimesh.Trimesh]:
    """Body, lens along -y, viewfinder hump on top, optional grip; widest along x."""
    width = rng.uniform(0.3, 0.4)
    height = width * rng.uniform(0.5, 0.65)
    depth = width * rng.uniform(0.28, 0.38)
    lens_r = height * rng.uniform(0.28, 0.36)
    lens_len = width * rng.uniform(0.15, 0.35)  # pancake to zoom lens
    lens_x = width * rng.uniform(-0.08, 0.08)
    hump_h = height * rng.uniform(0.18, 0.28)
    parts = [
        _box((width, depth, height), (0, 0, height / 2)),
        _cylinder(lens_r, lens_len + 0.01, (lens_x, -(depth + lens_len) / 2 + 0.005, height / 2), axis="y"),
        _hull(
            (_span(lens_x, 0.3 * width), _span(0, 0.8 * depth), (height - 0.01,) * 2),
            (_span(lens_x, 0.18 * width), _span(0, 0.6 * depth), (height + hump_h,) * 2),
        ),
    ]
    if rng.random() < 0.7:
        grip_w, grip_d = width * rng.uniform(0.14, 0.2), depth * rng.uniform(0.3, 0.45)
        grip_centre = (width / 2 - grip_w / 2, -(depth + grip_d) / 2 + 0.005, 0.45 * height)
        parts.append(_box((grip_w, grip_d + 0.01, 0.9 * height), grip_centre))
    return parts


_BUILDERS = {
    "car": _car, "chair": _chair, "table": _table, "sofa": _sofa, "airplane": _airplane, "camera": _camera,
}


def _object_class_name(cls: str | int) -> str:
    """The name of an object class given by name or id; ValueError for anything else."""
    try:
        name = CLASS_NAMES[class_id(cls)]
    except (TypeError, ValueError):
        name = None
    if name not in _BUILDERS:
        raise ValueError(f"no class mesh for class {cls!r}; object classes are: {', '.join(_BUILDERS)}")
    return name


def procedural_mesh(cls: str | int, seed: int) -> trimesh.Trimesh:
    """A watertight mesh of class ``cls`` (name or id) whose proportions are drawn with ``seed``.

    The parts are unioned with the manifold engine; the result is in metres, z up, resting on z = 0
    and centred in x/y. The same seed gives the same mesh, bit for bit.
    """
    name = _object_class_name(cls)
    parts = _BUILDERS[name](np.random.default_rng(seed))
    return _normalise(trimesh.boolean.union(parts, engine="manifold"))
