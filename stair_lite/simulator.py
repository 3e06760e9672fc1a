"""The simulated RGB-D camera with semantic labels: an offscreen pyrender renderer of a mesh scene.

Introduced in notebook 01. pyrender uses the OpenGL camera convention (y up, looking down -z); it
exists only inside this module. Everything outside speaks OpenCV camera-to-world poses.
"""
from __future__ import annotations

import numpy as np

import stair_lite  # noqa: F401  (the package sets PYOPENGL_PLATFORM before pyrender is imported)
from .classes import target_ids
from .geometry import Intrinsics, view_to_pose
from .measurement import Measurement
from .scenes import Scene

import pyrender  # noqa: E402  (after the platform is chosen)

OPENCV_TO_OPENGL = np.diag([1.0, -1.0, -1.0, 1.0])
Z_NEAR, Z_FAR = 0.05, 20.0
_RENDERER: pyrender.OffscreenRenderer | None = None


def shared_renderer(width: int, height: int) -> pyrender.OffscreenRenderer:
    """The process's one offscreen renderer, resized on demand.

    Creating renderers is slow, and deleting one terminates the EGL display that every other
    renderer of the process shares, so all simulators use this single instance.
    """
    global _RENDERER
    if _RENDERER is None:
        _RENDERER = pyrender.OffscreenRenderer(width, height)
    _RENDERER.viewport_width, _RENDERER.viewport_height = width, height
    return _RENDERER


class Simulator:
    """Renders rgb, z-depth and exact labels of a scene from any pose, reusing one offscreen renderer.

    The colour pass is unlit (``FLAT``): each face carries a colour baked with a world-fixed light,
    so colour is view-independent. Depth and labels come from the segmentation pass, whose pixels
    are sampled at their centres (no multisampling), so both are exact.
    """

    def __init__(self, scene: Scene, intrinsics: Intrinsics | None = None):
        self.scene = scene
        self.intrinsics = intrinsics or Intrinsics.from_fov()
        self._pyscene = pyrender.Scene(bg_color=[1.0, 1.0, 1.0, 1.0], ambient_light=[1.0, 1.0, 1.0])
        self._seg_ids, self._object_ids = {}, {}
        for position, (mesh, cls) in enumerate(scene.labelled_meshes()):  # the ground first, then the objects
            node = self._pyscene.add(pyrender.Mesh.from_trimesh(mesh, smooth=False))
            self._seg_ids[node] = cls + 1  # id 0 means "nothing hit", so classes are shifted by one
            self._object_ids[node] = position  # 0: the ground (or nothing); object i is i + 1
        self._camera_node = None
        self._camera_intrinsics = None
        self._set_camera(self.intrinsics)

    def _set_camera(self, intrinsics: Intrinsics):
        if self._camera_node is not None:
            self._pyscene.remove_node(self._camera_node)
        camera = pyrender.IntrinsicsCamera(
            intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy, znear=Z_NEAR, zfar=Z_FAR
        )
        self._camera_node = self._pyscene.add(camera, pose=np.eye(4))
        self._camera_intrinsics = intrinsics

    def _aim(self, pose: np.ndarray, intrinsics: Intrinsics) -> pyrender.OffscreenRenderer:
        """Put the camera, with these intrinsics, at an OpenCV camera-to-world pose; the renderer sized for it."""
        if intrinsics != self._camera_intrinsics:
            self._set_camera(intrinsics)
        self._pyscene.set_pose(self._camera_node, pose @ OPENCV_TO_OPENGL)
        return shared_renderer(intrinsics.width, intrinsics.height)

    def render(self, pose: np.ndarray, intrinsics: Intrinsics | None = None) -> Measurement:
        """One measurement (rgb, z-depth, labels) from an OpenCV camera-to-world pose, with the simulator's
        own intrinsics or, for this render only, the given ones."""
        pose = np.asarray(pose, dtype=np.float64)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be a finite 4x4 camera-to-world matrix, got shape {pose.shape}")
        intrinsics = intrinsics or self.intrinsics
        renderer = self._aim(pose, intrinsics)
        colour, _ = renderer.render(self._pyscene, flags=pyrender.RenderFlags.FLAT)
        seg, depth = renderer.render(
            self._pyscene, flags=pyrender.RenderFlags.SEG, seg_node_map=self._seg_ids
        )
        labels = np.where(seg[..., 0] > 0, seg[..., 0].astype(np.int64) - 1, 0)
        return Measurement(
            rgb=colour.astype(np.float32) / 255.0,
            depth=depth.astype(np.float32),
            labels=labels,
            pose=pose,
            intrinsics=intrinsics,
        )

    def render_view(self, elevation: float, azimuth: float, intrinsics: Intrinsics | None = None) -> Measurement:
        """Render the hemisphere view (elevation, azimuth), in radians."""
        return self.render(view_to_pose(elevation, azimuth), intrinsics)

    def objects_seen(self, elevation: float, azimuth: float) -> np.ndarray:
        """(H, W) index of the object each pixel of the view (elevation, azimuth) sees first, -1 where it sees
        the ground or nothing: one segmentation pass with an id per object instead of per class."""
        renderer = self._aim(view_to_pose(elevation, azimuth), self.intrinsics)
        seg, _ = renderer.render(self._pyscene, flags=pyrender.RenderFlags.SEG, seg_node_map=self._object_ids)
        return seg[..., 0].astype(np.int64) - 1


def target_only_image(m: Measurement, targets) -> np.ndarray:
    """The evaluation ground truth: the measured rgb with every non-target pixel set to white."""
    mask = np.isin(m.labels, target_ids(targets))
    return np.where(mask[..., None], m.rgb, np.float32(1.0)).astype(np.float32)
