"""The setup every notebook calls first: print options, the inline figure size, and what is installed."""
from __future__ import annotations

import platform

import numpy as np


def setup(seed: int = 0) -> np.random.Generator:
    """Prepare a notebook: short number printing, a fixed figure size, versions printed; returns a seeded RNG."""
    import matplotlib
    import matplotlib.pyplot as plt
    import torch

    import stair_lite

    np.set_printoptions(precision=4, suppress=True)
    plt.rcParams["figure.figsize"] = (8, 4)
    plt.rcParams["figure.dpi"] = 80
    torch.set_printoptions(precision=4, sci_mode=False)
    print(
        f"stair_lite {stair_lite.__version__} | python {platform.python_version()} | torch {torch.__version__} | "
        f"numpy {np.__version__} | matplotlib {matplotlib.__version__}"
    )
    return np.random.default_rng(seed)


def measured_floor(name: str, value: float, floor: float, measured: float) -> None:
    """A check against a floor set below a measured value (lite preset, seed 0, this repository's CPU), not a
    property: it catches a change that makes ``value`` fall well short of what was ``measured``."""
    print(f"measured-value check: {name} = {value:.4g} >= {floor:g} (floor set from the measured {measured:g})")
    assert value >= floor, f"{name} = {value:.4g} fell below its floor {floor:g} (measured {measured:g}): something changed"
