"""The seven semantic classes of the STAIR paper, their names and a fixed colour map.

Introduced in notebook 01. Class 0 is background (including the ground plane); the other six are
the object classes of the paper's simulator (Sec. IV-A).
"""
from __future__ import annotations

import numpy as np

CLASS_NAMES: tuple[str, ...] = ("background", "car", "chair", "table", "sofa", "airplane", "camera")
NUM_CLASSES = len(CLASS_NAMES)
BACKGROUND = 0

# One fixed RGB colour per class (floats in [0, 1]) for label images; same order as CLASS_NAMES. Each object class's
# label colour is a flat, saturated colour of its objects' base hue (``scenes.DEFAULT_COLOURS``: red cars, teal sofas),
# so an object's pixels and its label share a hue and no class's label takes another class's body colour; chair and
# table, both brown, differ in lightness.
CLASS_COLOURS = np.array(
    [
        [1.00, 1.00, 1.00],  # background: white
        [0.85, 0.10, 0.08],  # car: red
        [0.45, 0.24, 0.06],  # chair: dark brown
        [0.98, 0.80, 0.45],  # table: light tan
        [0.00, 0.62, 0.72],  # sofa: teal
        [0.22, 0.30, 0.95],  # airplane: blue
        [0.10, 0.10, 0.10],  # camera: near black
    ],
    dtype=np.float32,
)


def class_id(name_or_id: str | int) -> int:
    """Return the integer id of a class given its name (``"car"``) or id (``1``)."""
    if isinstance(name_or_id, (int, np.integer)) and not isinstance(name_or_id, bool):
        if not 0 <= int(name_or_id) < NUM_CLASSES:
            raise ValueError(f"class id {name_or_id!r} is outside the class range 0..{NUM_CLASSES - 1}")
        return int(name_or_id)
    if isinstance(name_or_id, str):
        key = name_or_id.strip().lower()
        if key in CLASS_NAMES:
            return CLASS_NAMES.index(key)
        raise ValueError(f"unknown class name {name_or_id!r}; known classes: {', '.join(CLASS_NAMES)}")
    raise TypeError(f"a class must be a name or an int id, got {type(name_or_id).__name__} {name_or_id!r}")


def class_name(cid: int) -> str:
    """Return the name of class id ``cid``."""
    return CLASS_NAMES[class_id(cid)]


def target_ids(targets) -> tuple[int, ...]:
    """Normalise target classes (names or ids, one or many) to a sorted tuple of object-class ids.

    Background cannot be a target: the paper's target set is a subset of {1, ..., P}.
    """
    if isinstance(targets, (str, int, np.integer)):
        targets = [targets]
    ids = sorted({class_id(t) for t in targets})
    if not ids:
        raise ValueError("the target class set is empty; name at least one object class")
    if BACKGROUND in ids:
        raise ValueError("background (class 0) cannot be a target class")
    return tuple(ids)


def colourise_labels(labels: np.ndarray) -> np.ndarray:
    """Map an integer label image (H, W) to an RGB image (H, W, 3) with the fixed class colours."""
    labels = np.asarray(labels)
    if labels.size and (labels.min() < 0 or labels.max() >= NUM_CLASSES):
        raise ValueError(f"labels outside the class range 0..{NUM_CLASSES - 1}: min {labels.min()}, max {labels.max()}")
    return CLASS_COLOURS[labels]
