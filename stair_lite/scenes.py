"""Scene specifications (small JSON files), scene building, the random scene generator and ground truth.

Introduced in notebook 01. A scene is a few class meshes standing on a ground plane (class 0) at
z = 0 inside the scene cube (``lattice.CUBE_BOUND``), plus the scene's default target classes (the paper's Sec. IV-A).
Every object carries a seeded albedo pattern over its surface (``surface_albedo``), so one glimpse of an
object does not tell its unseen sides' colours; a scene with ``"albedo": "uniform"`` gives each object
one colour instead (then colour carries no information a first glimpse lacks). Colour is baked into the mesh faces with a world-fixed
Lambert light, so what the camera sees of a surface does not depend on the viewpoint: the field has no
view dependence either.
"""
from __future__ import annotations

import colorsys
import hashlib
import json
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from .classes import BACKGROUND, CLASS_NAMES, class_id, target_ids
from .config import SEED_LIMIT
from .lattice import CUBE_BOUND
from .meshes import class_mesh

SCENE_DIR = Path(__file__).resolve().parent.parent / "data" / "scenes"
GROUND_SIZE = 2 * CUBE_BOUND  # the ground slab fills the cube's floor
GROUND_THICKNESS = 0.04
GROUND_COLOUR = (0.62, 0.60, 0.55)
LIGHT_DIRECTION = np.array([0.35, 0.55, 1.0]) / np.linalg.norm([0.35, 0.55, 1.0])  # towards the light
AMBIENT, DIFFUSE = 0.45, 0.55

ALBEDOS = ("pattern", "uniform")  # how a scene colours its objects (``SceneSpec.albedo``)
PATTERN_PERIOD = (0.1, 0.25)  # range of the seeded stripe periods of an albedo pattern, in object sizes
MIN_PERIOD = 0.06  # [m]: no stripe is finer than this (a lite grid cell is 4.8 cm)
FACE_EDGE = 0.03  # [m]: faces are split to at most this edge length before colouring, so patterns resolve

# A default base colour per class (floats), used when an object spec gives none.
DEFAULT_COLOURS = {
    "car": (0.80, 0.15, 0.12),
    "chair": (0.55, 0.35, 0.20),
    "table": (0.75, 0.60, 0.35),
    "sofa": (0.15, 0.45, 0.55),
    "airplane": (0.35, 0.40, 0.75),
    "camera": (0.15, 0.15, 0.18),
}


@dataclass(frozen=True)
class ObjectSpec:
    """One object: its class, mesh source ("procedural" or a real mesh name or file), pose and look."""

    cls: int
    position: tuple[float, float]
    yaw_deg: float = 0.0
    scale: float = 1.0
    mesh: str = "procedural"
    seed: int = 0
    colour: tuple[float, float, float] | None = None

    @property
    def class_name(self) -> str:
        return CLASS_NAMES[self.cls]


@dataclass(frozen=True)
class SceneSpec:
    """A whole scene: name, objects and the default target classes."""

    name: str
    objects: tuple[ObjectSpec, ...]
    targets: tuple[int, ...]
    description: str = ""
    albedo: str = "pattern"  # "pattern": seeded many-coloured surfaces; "uniform": one colour per object

    def __post_init__(self):
        if self.albedo not in ALBEDOS:
            raise ValueError(f"scene {self.name!r}: albedo must be one of {', '.join(ALBEDOS)}, got {self.albedo!r}")

    def to_json(self) -> dict:
        """The JSON form, with class names instead of ids."""
        objects = []
        for obj in self.objects:
            d = asdict(obj)
            d["class"] = CLASS_NAMES[d.pop("cls")]
            d["position"] = list(obj.position)
            if obj.colour is None:
                d.pop("colour")
            objects.append(d)
        return {
            "name": self.name,
            "description": self.description,
            "albedo": self.albedo,
            "targets": [CLASS_NAMES[t] for t in self.targets],
            "objects": objects,
        }


@lru_cache(maxsize=256)
def _unplaced_mesh(cls: int, source: str, seed: int) -> trimesh.Trimesh:
    """Class meshes are pure functions of (class, source, seed): build each once per process."""
    return class_mesh(cls, source, seed=seed)


def surface_albedo(points: np.ndarray, colour, seed: int, size: float = 1.0) -> np.ndarray:
    """A seeded albedo (N, 3) at surface points (N, 3) given in the object's own frame: two crossed
    stripe patterns (seeded directions at most 45 degrees from the horizontal, so that tops are striped
    too) pick, per patch, one of three colours: the base colour, a light tint of it, and an accent of a
    seeded hue away from the base's (a third of the colour wheel either side of its opposite); the periods are fractions ``PATTERN_PERIOD``
    of the object's ``size`` [m], at least ``MIN_PERIOD``. The pattern moves with the object."""
    rng = np.random.default_rng(seed)
    heading, tilt = rng.uniform(0.0, 2 * np.pi, size=2), rng.uniform(-np.pi / 4, np.pi / 4, size=2)
    directions = np.stack([np.cos(tilt) * np.cos(heading), np.cos(tilt) * np.sin(heading), np.sin(tilt)], axis=1)
    periods = np.maximum(size * rng.uniform(*PATTERN_PERIOD, size=2), MIN_PERIOD)
    phases = rng.uniform(0.0, 1.0, size=2)
    base = np.asarray(colour, dtype=np.float64)
    hue = colorsys.rgb_to_hsv(*base)[0] + 0.5 + rng.uniform(-1 / 3, 1 / 3)
    accent = np.array(colorsys.hsv_to_rgb(hue % 1.0, 0.75, 0.9))
    palette = np.stack([base, 0.5 * (base + 1.0), accent])
    stripes = np.floor(points @ directions.T / periods + phases).astype(np.int64)  # (N, 2) stripe numbers
    return palette[(stripes[:, 0] + 2 * stripes[:, 1]) % 3]


def _bake_colour(mesh: trimesh.Trimesh, albedo) -> trimesh.Trimesh:
    """Give every face a view-independent colour: albedo * (ambient + diffuse * max(0, n . l)); ``albedo``
    is one colour (3,) or one per face (F, 3)."""
    shade = AMBIENT + DIFFUSE * np.clip(mesh.face_normals @ LIGHT_DIRECTION, 0.0, None)
    albedo = np.broadcast_to(np.asarray(albedo, dtype=np.float64), (len(shade), 3))
    rgb = np.clip(albedo * shade[:, None], 0.0, 1.0)
    rgba = np.concatenate([np.round(rgb * 255), np.full((len(rgb), 1), 255)], axis=1).astype(np.uint8)
    mesh = mesh.copy()
    mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=rgba)
    return mesh


def _patterned(mesh: trimesh.Trimesh, placement: np.ndarray, colour, seed: int) -> trimesh.Trimesh:
    """The placed ``mesh`` with faces split to ``FACE_EDGE`` and baked with its albedo pattern, which is
    evaluated in the object's frame (``placement`` maps that frame to the world)."""
    vertices, faces = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=FACE_EDGE)
    fine = trimesh.Trimesh(vertices, faces, process=False)
    local = trimesh.transform_points(fine.triangles_center, np.linalg.inv(placement))
    size = float(np.max(mesh.extents))
    return _bake_colour(fine, surface_albedo(local, colour, seed, size))


def ground_mesh() -> trimesh.Trimesh:
    """The rendered ground: a thin slab whose top face is the z = 0 plane, filling the cube's floor."""
    slab = trimesh.creation.box(extents=(GROUND_SIZE, GROUND_SIZE, GROUND_THICKNESS))
    slab.apply_translation((0.0, 0.0, -GROUND_THICKNESS / 2))
    return _bake_colour(slab, GROUND_COLOUR)


def _convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """Andrew's monotone chain: the convex hull of 2-D points, counter-clockwise."""
    pts = np.unique(np.round(points, 9), axis=0)
    if len(pts) <= 2:
        return pts

    def turn(o, a, b):  # z component of (a - o) x (b - o): > 0 for a left turn
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(seq):
        hull = []
        for p in seq:
            while len(hull) >= 2 and turn(hull[-2], hull[-1], p) <= 0:
                hull.pop()
            hull.append(p)
        return hull

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _polygons_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test for two convex polygons: True when their interiors intersect."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for normal in np.stack([-edges[:, 1], edges[:, 0]], axis=1):
            pa, pb = a @ normal, b @ normal
            if pa.max() <= pb.min() + 1e-9 or pb.max() <= pa.min() + 1e-9:
                return False
    return True


def meshes_interpenetrate(a: trimesh.Trimesh, b: trimesh.Trimesh) -> bool:
    """Whether two placed objects intersect.

    Watertight meshes (all procedural ones) get an exact test: the volume of their boolean
    intersection. Other meshes have no inside, so their ground footprints (convex hulls) must not
    overlap, a conservative stand-in.
    """
    (alo, ahi), (blo, bhi) = a.bounds, b.bounds
    if np.any(ahi <= blo) or np.any(bhi <= alo):
        return False
    if a.is_watertight and b.is_watertight:
        common = trimesh.boolean.intersection([a, b], engine="manifold")
        return len(common.faces) > 0 and common.volume > 1e-7
    return _polygons_overlap(_convex_hull_2d(a.vertices[:, :2]), _convex_hull_2d(b.vertices[:, :2]))


@dataclass
class Scene:
    """A built scene: world-frame, colour-baked meshes of the objects, and the ground."""

    spec: SceneSpec
    object_meshes: list[trimesh.Trimesh] = field(repr=False)
    ground: trimesh.Trimesh = field(repr=False)

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def targets(self) -> tuple[int, ...]:
        return self.spec.targets

    @property
    def object_classes(self) -> list[int]:
        return [obj.cls for obj in self.spec.objects]

    @property
    def classes_present(self) -> tuple[int, ...]:
        """Object classes that occur in this scene (sorted ids)."""
        return tuple(sorted(set(self.object_classes)))

    def check_targets(self, targets) -> tuple[int, ...]:
        """Normalise ``targets`` and refuse classes that do not occur in the scene."""
        ids = target_ids(targets)
        missing = [CLASS_NAMES[t] for t in ids if t not in self.classes_present]
        if missing:
            present = ", ".join(CLASS_NAMES[c] for c in self.classes_present)
            raise ValueError(f"target classes {missing} do not occur in scene {self.name!r} (it has: {present})")
        return ids

    def labelled_meshes(self) -> list[tuple[trimesh.Trimesh, int]]:
        """Every mesh with its class id, ground first."""
        return [(self.ground, BACKGROUND)] + list(zip(self.object_meshes, self.object_classes))

    def targets_alone(self, targets=None) -> "Scene":
        """This scene with only its target objects on the ground (the other objects removed)."""
        ids = self.check_targets(self.targets if targets is None else targets)
        keep = [i for i, c in enumerate(self.object_classes) if c in ids]
        spec = replace(self.spec, objects=tuple(self.spec.objects[i] for i in keep))
        return Scene(spec=spec, object_meshes=[self.object_meshes[i] for i in keep], ground=self.ground)

    def target_mesh(self, targets=None) -> trimesh.Trimesh:
        """The ground-truth mesh of the target objects only (what the paper's mesh metrics compare to)."""
        ids = self.check_targets(self.targets if targets is None else targets)
        parts = [m for m, c in zip(self.object_meshes, self.object_classes) if c in ids]
        return trimesh.util.concatenate(parts)


def build_scene(spec: SceneSpec) -> Scene:
    """Build meshes for a spec, placing each object, and check it is a valid scene.

    Raises ValueError when an object leaves the cube or two objects interpenetrate.
    """
    meshes, placed = [], []
    for index, obj in enumerate(spec.objects):
        mesh = _unplaced_mesh(obj.cls, obj.mesh, obj.seed).copy()
        if obj.scale <= 0:
            raise ValueError(f"object {index} ({obj.class_name}): scale must be positive, got {obj.scale!r}")
        mesh.apply_scale(obj.scale)
        if mesh.extents.max() < MIN_OBJECT_SIZE:
            raise ValueError(f"object {index} ({obj.class_name}) is {mesh.extents.max():.3g} m across at scale {obj.scale!r}; "
                             f"objects must be at least {MIN_OBJECT_SIZE} m across to be seen in the test views")
        placement = trimesh.transformations.rotation_matrix(np.radians(obj.yaw_deg), (0, 0, 1))
        placement[:2, 3] = obj.position
        mesh.apply_transform(placement)
        lo, hi = mesh.bounds
        if np.any(lo < -CUBE_BOUND) or np.any(hi > CUBE_BOUND):
            raise ValueError(
                f"object {index} ({obj.class_name}) at position {list(obj.position)} extends outside the scene cube "
                f"[-{CUBE_BOUND}, {CUBE_BOUND}]^3: bounds {np.round(lo, 3).tolist()} .. {np.round(hi, 3).tolist()}"
            )
        for other, other_mesh in enumerate(placed):
            if meshes_interpenetrate(mesh, other_mesh):
                raise ValueError(
                    f"objects {other} ({spec.objects[other].class_name}) and {index} ({obj.class_name}) overlap "
                    f"(positions {list(spec.objects[other].position)} and {list(obj.position)})"
                )
        placed.append(mesh)
        colour = obj.colour if obj.colour is not None else DEFAULT_COLOURS[obj.class_name]
        meshes.append(_patterned(mesh, placement, colour, obj.seed) if spec.albedo == "pattern" else _bake_colour(mesh, colour))
    return Scene(spec=spec, object_meshes=meshes, ground=ground_mesh())


MIN_OBJECT_SIZE = 0.05  # metres: an object smaller than a test view's pixel at 2 m (4 cm) may never be seen


def _require(d: dict, key: str, where: str):
    if key not in d:
        raise ValueError(f"{where}: missing field {key!r}")
    return d[key]


def _number(value, where: str, what: str) -> float:
    """A finite JSON number (true and false are not numbers here, although Python counts them as ints)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ValueError(f"{where}: {what} must be a finite number, got {value!r}")
    return float(value)


def spec_from_json(data: dict, source: str = "scene") -> SceneSpec:
    """Validate a scene's JSON dictionary and turn it into a SceneSpec (errors name the field and value)."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a scene must be a JSON object, got {type(data).__name__}")
    raw_objects = _require(data, "objects", source)
    if not isinstance(raw_objects, list) or not raw_objects:
        raise ValueError(f"{source}: 'objects' must be a non-empty list, got {raw_objects!r}")
    objects = []
    for i, o in enumerate(raw_objects):
        where = f"{source}: object {i}"
        if not isinstance(o, dict):
            raise ValueError(f"{where} must be a JSON object, got {o!r}")
        position = _require(o, "position", where)
        if not (isinstance(position, (list, tuple)) and len(position) == 2):
            raise ValueError(f"{where}: 'position' must be [x, y] in metres, got {position!r}")
        x, y = (_number(p, where, f"'position' {axis}") for p, axis in zip(position, "xy"))
        colour = o.get("colour")
        if colour is not None and not (isinstance(colour, (list, tuple)) and len(colour) == 3
                                       and all(0.0 <= _number(c, where, "'colour'") <= 1.0 for c in colour)):
            raise ValueError(f"{where}: 'colour' must be three numbers in [0, 1], got {colour!r}")
        seed = o.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < SEED_LIMIT:
            raise ValueError(f"{where}: 'seed' must be an integer in [0, 2^32), got {seed!r}")
        try:
            cls = class_id(_require(o, "class", where))
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where}: 'class' {o['class']!r} is not a class ({err})") from None
        objects.append(
            ObjectSpec(
                cls=cls,
                position=(x, y),
                yaw_deg=_number(o.get("yaw_deg", 0.0), where, "'yaw_deg'"),
                scale=_number(o.get("scale", 1.0), where, "'scale'"),
                mesh=str(o.get("mesh", "procedural")),
                seed=seed,
                colour=None if colour is None else tuple(float(c) for c in colour),
            )
        )
    classes = {obj.cls for obj in objects}
    targets = target_ids(_require(data, "targets", source))
    missing = [CLASS_NAMES[t] for t in targets if t not in classes]
    if missing:
        raise ValueError(f"{source}: targets {missing} do not occur among the scene's objects")
    return SceneSpec(
        name=str(data.get("name", source)), objects=tuple(objects), targets=targets, description=str(data.get("description", "")),
        albedo=str(data.get("albedo", "pattern")),
    )


def list_scenes() -> list[str]:
    """Names of the scenes shipped in data/scenes."""
    return sorted(p.stem for p in SCENE_DIR.glob("*.json"))


MAX_SCENE_FILE_BYTES = 10 * 2**20  # a scene of 1,000 objects is about 200 kB


def scene_path(name_or_path: str | Path) -> Path:
    """The JSON file of a scene: a shipped scene's ("scene1") in data/scenes, or the given path, which must be a
    regular file (not a device or a pipe, also behind a link) of at most ``MAX_SCENE_FILE_BYTES``."""
    path = Path(name_or_path)
    if path.suffix != ".json":
        shipped = SCENE_DIR / f"{name_or_path}.json"
        if not shipped.exists():
            hint = f" ({path} exists, but a scene file's name ends in .json)" if path.exists() else ""
            raise ValueError(f"unknown scene {str(name_or_path)!r}{hint}; shipped scenes: {', '.join(list_scenes())}")
        path = shipped
    if not path.exists():
        raise FileNotFoundError(f"scene file not found: {path}")
    if not path.is_file():
        raise ValueError(f"scene file {path} is not a regular file (a device, a pipe or a folder)")
    size = path.stat().st_size
    if size > MAX_SCENE_FILE_BYTES:
        raise ValueError(f"scene file {path} holds {size} bytes, more than a scene needs ({MAX_SCENE_FILE_BYTES})")
    return path


def load_scene_spec(name_or_path: str | Path) -> SceneSpec:
    """Read a scene spec by shipped name ("scene1") or by path to a JSON file."""
    path = scene_path(name_or_path)
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"scene file {path} is not valid JSON: {err}") from None
    return spec_from_json(data, source=str(path))


def scene_key(name_or_path: str | Path) -> str:
    """The name a scene goes by in results folders: a shipped scene's name, a scene file's stem."""
    path = Path(name_or_path)
    return path.stem if path.suffix == ".json" else str(name_or_path)


def scene_content_hash(name_or_path: str | Path) -> str:
    """sha256 of a scene's JSON file, shipped or not: a sweep records it per results folder name, so that a
    scene file named like a shipped scene (or edited since) is never mixed with the results of another scene."""
    return hashlib.sha256(scene_path(name_or_path).read_bytes()).hexdigest()[:16]


def scene_file_hash(name_or_path: str | Path) -> str | None:
    """``scene_content_hash`` of a scene file, None for a shipped scene: a mission records it, so that one resumed
    after the file was edited is refused (a mission of a shipped scene records its name)."""
    return scene_content_hash(name_or_path) if Path(name_or_path).suffix == ".json" else None


def load_scene(name_or_path: str | Path) -> Scene:
    """Load and build a scene by shipped name or JSON path."""
    return build_scene(load_scene_spec(name_or_path))


def save_scene_spec(spec: SceneSpec, path: str | Path) -> Path:
    """Write a spec as JSON (the format ``load_scene_spec`` reads)."""
    path = Path(path)
    data = spec.to_json()
    objects = ",\n".join(f"    {json.dumps(o)}" for o in data.pop("objects"))
    head = json.dumps(data, indent=2)[:-2]  # drop the closing brace: objects follow, one per line
    path.write_text(f"{head},\n  \"objects\": [\n{objects}\n  ]\n}}\n")
    return path


def place_objects(items, rng: np.random.Generator, max_radius: float = 1.0, max_tries: int = 200) -> tuple[ObjectSpec, ...]:
    """Place objects one by one at random positions within ``max_radius`` of the origin and random yaw.

    ``items`` are (class, mesh source) pairs; a position is redrawn until the object stays inside
    the cube and touches no object placed before it.
    """
    placed: list[ObjectSpec] = []
    for cls, source in items:
        cls = class_id(cls)
        for _ in range(max_tries):
            radius, angle = max_radius * np.sqrt(rng.uniform()), rng.uniform(0, 2 * np.pi)
            candidate = ObjectSpec(
                cls=cls,
                position=(round(float(radius * np.cos(angle)), 3), round(float(radius * np.sin(angle)), 3)),
                yaw_deg=round(float(rng.uniform(0, 360)), 1),
                mesh=source,
                seed=int(rng.integers(0, 10_000)),
            )
            try:
                build_scene(SceneSpec("probe", tuple(placed + [candidate]), (cls,), albedo="uniform"))  # geometry only
            except ValueError:
                continue
            placed.append(candidate)
            break
        else:
            raise ValueError(f"could not place an object of class {CLASS_NAMES[cls]!r} without overlap in {max_tries} tries")
    return tuple(placed)


def random_scene_spec(
    seed: int,
    n_objects: int = 6,
    targets=("car",),
    classes=("car", "chair", "table", "sofa", "airplane", "camera"),
    max_radius: float = 1.0,
) -> SceneSpec:
    """A seeded random scene of ``n_objects`` procedural objects; every target class appears at least once."""
    if n_objects < 1:
        raise ValueError(f"a scene needs at least one object, got n_objects={n_objects!r}")
    rng = np.random.default_rng(seed)
    target_list = list(target_ids(targets))
    if n_objects < len(target_list):
        raise ValueError(f"n_objects={n_objects} is fewer than the {len(target_list)} target classes")
    pool = [class_id(c) for c in classes]
    wanted = target_list + [int(rng.choice(pool)) for _ in range(n_objects - len(target_list))]
    objects = place_objects([(c, "procedural") for c in wanted], rng, max_radius)
    return SceneSpec(name=f"random_{seed}", objects=objects, targets=tuple(target_list), description=f"random scene, seed {seed}")
