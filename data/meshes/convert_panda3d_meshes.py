"""Convert a few Panda3D models into small OBJ files for stair_lite (run once; needs panda3d).

    pip install panda3d==1.10.16 panda3d-assetcoop==0.15
    python data/meshes/convert_panda3d_meshes.py

Panda3D's own formats (.bam, .egg.pz) are not readable by trimesh, so this script loads them with
Panda3D's loader (which converts every model to Panda3D's z-up frame), flattens the transforms,
merges vertices by position and writes one object per OBJ file: positions and triangles only, no
normals, UVs or materials. Objects cut out of the apartment scene keep their own scale, pitch and
roll but lose their placement (position and heading) in the room. Units stay the source's; the
stair_lite loader rescales. It then rewrites the sha256 table in SOURCES.md. Nothing else in the
repository imports panda3d.
"""
from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import numpy as np
from panda3d.core import Filename, GeomVertexReader, Loader, NodePath, TransformState

import assetcoop
import panda3d

OUT_DIR = Path(__file__).resolve().parent
ASSETCOOP = Path(assetcoop.__file__).parent / "bam" / "models"
PANDA_MODELS = Path(panda3d.__file__).parent / "models"

# output file: (source file, group name inside it or None for the whole model)
JOBS = {
    "sofa_assetcoop.obj": (ASSETCOOP / "scenes" / "appartment.bam", "sofa"),
    "armchair_assetcoop.obj": (ASSETCOOP / "scenes" / "appartment.bam", "armchair"),
    "chair_assetcoop.obj": (ASSETCOOP / "scenes" / "appartment.bam", "chair"),
    "table_assetcoop.obj": (ASSETCOOP / "scenes" / "appartment.bam", "kitchen_table"),
    "coffeetable_assetcoop.obj": (ASSETCOOP / "scenes" / "appartment.bam", "coffeetable"),
    "car_flyingcar.obj": (ASSETCOOP / "other" / "flyingcar.bam", None),
    "camera_panda3d.obj": (PANDA_MODELS / "camera.egg.pz", None),
    "teapot_panda3d.obj": (PANDA_MODELS / "teapot.egg.pz", None),
}


def load_model(path: Path) -> NodePath:
    """Load a .bam or .egg(.pz) file with Panda3D's loader (no window needed)."""
    node = Loader.get_global_ptr().load_sync(Filename.from_os_specific(str(path)))
    if node is None:
        raise RuntimeError(f"Panda3D could not load {path}")
    return NodePath(node)


def object_frame(obj: NodePath) -> TransformState:
    """The object's own transform without its placement in the scene (position and heading)."""
    ts = obj.get_transform()
    hpr = ts.get_hpr()
    return TransformState.make_pos_hpr_scale_shear((0, 0, 0), (0, hpr[1], hpr[2]), ts.get_scale(), ts.get_shear())


def triangles(obj: NodePath, frame: TransformState) -> tuple[np.ndarray, np.ndarray]:
    """All triangles under ``obj`` in ``frame``: (vertices (n, 3), faces (m, 3)), vertices merged by position."""
    verts, faces = [], []
    for geom_np in obj.find_all_matches("**/+GeomNode"):
        mat = geom_np.get_mat(obj) * frame.get_mat()
        flip = mat.get_upper_3().determinant() < 0
        for geom in geom_np.node().get_geoms():
            reader = GeomVertexReader(geom.get_vertex_data(), "vertex")
            pts = []
            while not reader.is_at_end():
                p = mat.xform_point(reader.get_data3())
                pts.append((p[0], p[1], p[2]))
            offset = sum(len(v) for v in verts)
            verts.append(np.array(pts, dtype=np.float64))
            for prim in geom.decompose().get_primitives():
                idx = np.array([prim.get_vertex(i) for i in range(prim.get_num_vertices())]).reshape(-1, 3)
                faces.append((idx[:, ::-1] if flip else idx) + offset)
    v = np.round(np.concatenate(verts), 5) + 0.0  # + 0.0 turns -0.0 into 0.0
    f = np.concatenate(faces)
    unique, inverse = np.unique(v, axis=0, return_inverse=True)
    f = inverse.reshape(-1)[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]  # drop degenerate
    return unique, f


def write_obj(path: Path, name: str, source: str, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write a minimal, deterministic OBJ file."""
    lines = [f"# {name}: converted from {source} by convert_panda3d_meshes.py", f"o {name}"]
    lines += [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def update_sources_md() -> None:
    """Rewrite the sha256 column of SOURCES.md for every converted file."""
    md = OUT_DIR / "SOURCES.md"
    text = md.read_text()
    for out_name in JOBS:
        digest = hashlib.sha256((OUT_DIR / out_name).read_bytes()).hexdigest()
        text = re.sub(rf"(\| `{re.escape(out_name)}` \|.*\| )`[0-9a-f]*`( \|)", rf"\g<1>`{digest}`\g<2>", text)
    md.write_text(text)


def main() -> None:
    for out_name, (src, group) in JOBS.items():
        root = load_model(src)
        if group is None:
            obj, frame = root, TransformState.make_identity()
        else:
            obj = root.find(f"**/{group}")
            if obj.is_empty():
                raise RuntimeError(f"group {group!r} not found in {src}")
            frame = object_frame(obj)
        v, f = triangles(obj, frame)
        source = os.path.relpath(src, Path(panda3d.__file__).parent.parent) + (f" group {group}" if group else "")
        write_obj(OUT_DIR / out_name, Path(out_name).stem, source, v, f)
        print(f"{out_name}: {len(v)} vertices, {len(f)} faces, extent {np.ptp(v, axis=0).round(3)}")
    update_sources_md()


if __name__ == "__main__":
    main()
