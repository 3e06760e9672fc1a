"""The seven semantic classes of the STAIR paper, their names and a fixed colour map.

Introduced in notebook 01. Class 0 is background (including the ground plane); the other six are
the object classes of the paper's simulator (Sec. IV-A).
"""
from __future__ import annotations

import numpy as np

CLASS_NAMES: tuple[str, ...] = ("background", "car", "chair", "table", "sofa", "airplane", "camera")
NUM_CLASSES = len(CLASS_NAMES)
BACKGROUND = 0

# One fixed RGB colour per class (floats in [0, 1]) for label images; same order as CLASS_NAMES.
CLASS_COLOURS = np.array(
    [
        [1.00, 1.00, 1.00],  # background: white
        [0.40, 0.40, 0.40],  # car: grey
        [0.00, 0.00, 1.00],  # chair: blue
        [0.00, 1.00, 1.00],  # table: cyan
        [1.00, 0.00, 0.00],  # sofa: red
        [0.40, 0.00, 0.80],  # airplane: purple
        [0.00, 0.40, 0.00],  # camera: dark green
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
