"""The authors' step as ``authors_step.py`` measured it, kept with the machine it ran on, so that
``bench_paper_cpu.py`` compares our step with theirs only on the same CPU (standard library only: their environment
imports it too; the CPU's name comes from ``stair_lite/machine.py``, loaded as a file)."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

RECORD_DEFAULT = "runs/authors/step.json"

# the package's cpu_model, loaded from its file: the authors' environment does not have the package installed
_spec = importlib.util.spec_from_file_location("stair_lite_machine", Path(__file__).parents[1] / "stair_lite" / "machine.py")
_machine = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_machine)
cpu_model = _machine.cpu_model


def write_record(path: str, **figures) -> None:
    """Store the figures of one run of ``authors_step.py`` with this machine's CPU."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps({"cpu": cpu_model(), **figures}, indent=1) + "\n")


def read_record(path: str) -> dict | None:
    """The stored figures when they were measured on this machine's CPU (None when missing or from another CPU)."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return record if record.get("cpu") == cpu_model() else None
