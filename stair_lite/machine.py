"""Which machine produced a result: the CPU, by name and family, model and stepping. Float sums, and so a mission's last
bits and at a near tie its views, depend on the CPU's kernels and on the number of threads (RESULTS.md, "At the paper's
scale": a class tie an AMD EPYC broke where an Intel Xeon did not), so every mission step records both. Standard
library only: ``benchmarks/authors_record.py`` loads this file in the authors' environment, where the package is not
installed."""
from __future__ import annotations

import platform
from pathlib import Path


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
