"""The per-step metrics of a mission, registered once: each describes itself (its record column, axis label,
direction, the decimals it is shown with) and says how it is computed from an evaluation.

Introduced in notebook 05. A mission records every registered metric after every step; the results table, the
report's summary and curves, the claims and the headroom instrument iterate ``METRICS`` and name none of them.
A new metric is one ``register_metric`` call (README, "Design"): either a value the evaluator already returns
(``Evaluator.evaluate``, the default) or ``compute(evaluation, map)`` of the evaluation's result and the evaluated map.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

OCCUPIED = 0.5  # the occupancy (or occupancy probability) above which a map's point counts as occupied


@dataclass(frozen=True)
class Metric:
    """One column of a mission's records. ``compared``: the claims compare variants on it (precision, completeness and
    the phantom are recorded to explain the scores, not compared); ``report_scale``: the report shows value x scale."""

    column: str
    label: str
    lower_is_better: bool = False
    digits: int = 3
    compared: bool = True
    report_scale: float = 1.0
    compute: Callable | None = None  # (evaluation result, map) -> float; None: the evaluation's own value

    def value(self, evaluation: dict, reconstruction=None) -> float:
        """This metric of one evaluation (``Evaluator.evaluate``'s result) of ``reconstruction``."""
        return evaluation[self.column] if self.compute is None else float(self.compute(evaluation, reconstruction))

    def gain(self, before: float, after: float) -> float:
        """The improvement from ``before`` to ``after`` (a reduction where lower is better)."""
        return before - after if self.lower_is_better else after - before


METRICS: dict[str, Metric] = {}


def register_metric(metric: Metric) -> Metric:
    """Add a metric to every mission's records from now on (a name already taken is refused)."""
    if metric.column in METRICS:
        raise ValueError(f"a metric named {metric.column!r} is already registered")
    METRICS[metric.column] = metric
    return metric


def unregister_metric(column: str) -> None:
    """Remove a metric registered by ``register_metric`` (e.g. a test's)."""
    METRICS.pop(column)


def compared_metrics() -> tuple[str, ...]:
    """The columns the claims compare, in registration order."""
    return tuple(m.column for m in METRICS.values() if m.compared)


for _metric in (
    Metric("psnr", "target-only PSNR [dB]", digits=2),
    Metric("psnr_clean", "target-only PSNR, clean protocol [dB]", digits=2),
    Metric("precision", "target mesh precision (1 cm)", compared=False),
    Metric("completeness", "target mesh completeness (1 cm)", compared=False),
    Metric("f1", "target mesh F1 (1 cm)"),
    Metric("f1_2cm", "target mesh F1 (2 cm)"),
    Metric("f1_5cm", "target mesh F1 (5 cm)"),
    Metric("chamfer", "target mesh chamfer distance [m]", lower_is_better=True, digits=4, report_scale=100.0),
    Metric("phantom", "occupied share below the ground", lower_is_better=True, digits=4, compared=False),
):
    register_metric(_metric)
