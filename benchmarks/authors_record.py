"""The authors' step as ``authors_step.py`` measured it, kept with the machine it ran on, so that
``bench_paper_cpu.py`` compares our step with theirs only on the same CPU (standard library only: their environment
imports it too)."""
from __future__ import annotations

import json
import platform
from pathlib import Path

RECORD_DEFAULT = "runs/authors/step.json"


def cpu_model() -> str:
    """This machine's CPU, as Linux names it, with its family, model and stepping numbers (a virtual machine's name may
    say only "Intel(R) Xeon(R) Processor"); ``platform.processor()`` elsewhere."""
    try:
        fields = dict(line.split(":", 1) for line in Path("/proc/cpuinfo").read_text().split("\n\n")[0].splitlines()
                      if ":" in line)
    except OSError:
        return platform.processor() or "unknown"
    fields = {key.strip(): value.strip() for key, value in fields.items()}
    return (f"{fields.get('model name', 'unknown')} (family {fields.get('cpu family', '?')}, model "
            f"{fields.get('model', '?')}, stepping {fields.get('stepping', '?')})")


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
