"""Figures of notebook 06 (the comparison with the baselines)."""
from __future__ import annotations

import matplotlib.pyplot as plt

from ..claims import TOO_FEW_PAIRS
from ..metrics import METRICS

VERDICT_COLOURS = {"holds": "tab:green", "reversed": "tab:red", "not significant": "tab:grey",
                   TOO_FEW_PAIRS: "tab:grey"}


def _difference(ax, x: float, c, hollow: bool = False) -> None:
    """One comparison's mean paired difference at ``x`` with its 95 % confidence interval, coloured by its verdict."""
    low, high = c.interval()
    colour = VERDICT_COLOURS[c.verdict]
    ax.errorbar(x, c.difference, yerr=[[c.difference - low], [high - c.difference]], fmt="o", capsize=3, color=colour,
                mfc="white" if hollow else colour)


def _panel(ax, labels: list[str], metric: str, title: str) -> None:
    """The zero line, the x labels and the title of one panel; the axis flipped where lower is better."""
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(labels)), labels, fontsize=7)
    if METRICS[metric].lower_is_better:
        ax.invert_yaxis()
    ax.set_title(f"{title}: {METRICS[metric].label}", fontsize=8)
    ax.grid(axis="y", alpha=0.3)


def _verdict_handles() -> list:
    return [plt.Line2D([], [], marker="o", ls="", color=c, label=v) for v, c in VERDICT_COLOURS.items()]


def plot_claim_differences(claims: dict[str, list], metrics: tuple[str, ...]):
    """One row per claim (``claims``: title -> its ``claims.Comparison`` list), one panel per metric: per scene, the mean
    paired difference (claimed side minus the other, over the seeds) with its 95 % confidence interval, coloured by the
    verdict. For a metric where lower is better the axis is flipped, so up is always better for the claimed side."""
    fig, axes = plt.subplots(len(claims), len(metrics), figsize=(3.6 * len(metrics), 2.6 * len(claims)), squeeze=False)
    for row, (title, comparisons) in zip(axes, claims.items()):
        for ax, metric in zip(row, metrics):
            mine = [c for c in comparisons if c.metric == metric]
            for x, c in enumerate(mine):
                _difference(ax, x, c)
            _panel(ax, [f"{c.scene}\n{c.other}" for c in mine], metric, title)
        row[0].set_ylabel("claimed minus other", fontsize=8)
    fig.legend(handles=_verdict_handles(), loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig


def plot_scale_differences(entries: list[dict], metrics: tuple[str, ...],
                           columns: dict[str, str] | None = None):
    """``scale_study.side_by_side``'s entries: one row per claim, one panel per metric; per scene (and pooled) the
    mean paired difference with its 95 % confidence interval at each scale side by side (hollow: lite over as many
    seeds as the paper scale finished; filled: the paper scale), coloured by the verdict; up is better for STAIR."""
    columns = columns or {"lite, as many seeds as the paper scale": "lite_same", "paper scale": "paper"}
    claims = sorted({e["claim"] for e in entries})
    fig, axes = plt.subplots(len(claims), len(metrics), figsize=(3.6 * len(metrics), 2.6 * len(claims)), squeeze=False)
    for row, claim in zip(axes, claims):
        for ax, metric in zip(row, metrics):
            mine = [e for e in entries if (e["claim"], e["metric"]) == (claim, metric)]
            for x, e in enumerate(mine):
                for k, column in enumerate(columns.values()):
                    _difference(ax, x + 0.3 * (k - 0.5), e[column], hollow=k == 0)
            _panel(ax, [e["scene"] for e in mine], metric, f"claim {claim}")
        row[0].set_ylabel("claimed minus other", fontsize=8)
    handles = _verdict_handles() + [plt.Line2D([], [], marker="o", ls="", color="k", mfc=("white" if k == 0 else "k"),
                                               label=name) for k, name in enumerate(columns)]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig
