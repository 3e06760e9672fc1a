"""Figures of notebook 08 (what a view teaches: the league of utilities, from one view to a mission)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..plotting import planner_colour


def plot_league(rows: list[dict], metrics: tuple[str, ...], measures=(("pick_percentile", "pick: share of spread views beaten"),
                                                                      ("spearman", "rho: Spearman with the realised gain"))):
    """``headroom.league`` rows as bars: one panel per measure (rows) and metric (columns), a bar per utility, the noise
    ceiling (utility "ceiling") as a dashed line and a random view's expectation (a pick beats half the views, rho 0)
    as a dotted one."""
    utilities = [u for u in dict.fromkeys(r["utility"] for r in rows) if u != "ceiling"]
    value = {(r["utility"], r["metric"]): r for r in rows}
    fig, axes = plt.subplots(len(measures), len(metrics), figsize=(3.4 * len(metrics), 3.2 * len(measures)),
                             squeeze=False, sharey="row")
    for row, (measure, label) in zip(axes, measures):
        for ax, metric in zip(row, metrics):
            heights = [value[(u, metric)][measure] for u in utilities]
            ax.bar(range(len(utilities)), heights, color=[planner_colour(u) for u in utilities])
            if ("ceiling", metric) in value:
                ax.axhline(value[("ceiling", metric)][measure], color="k", ls="--", lw=1, label="noise ceiling")
            ax.axhline(0.5 if measure == "pick_percentile" else 0.0, color="grey", ls=":", lw=1, label="a random view")
            ax.set_xticks(range(len(utilities)), utilities, rotation=60, ha="right", fontsize=7)
            ax.set_title(metric, fontsize=9)
            ax.grid(axis="y", alpha=0.3)
        row[0].set_ylabel(label, fontsize=8)
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_view_to_mission(points: list[dict], metric: str, ax=None):
    """Per planner (``points``: planner, rho (its utility's league Spearman with one view's gain), mission score, view
    spread): how well its utility ranks one view against how its missions score, the view spread as the marker size."""
    ax = ax or plt.gca()
    spreads = np.array([p["spread_deg"] for p in points])
    for p in points:
        ax.scatter(p["rho"], p["mission"], s=4 * p["spread_deg"], color=planner_colour(p["planner"]), alpha=0.8,
                   edgecolor="k", linewidth=0.5)
        ax.annotate(f"{p['planner']} ({p['spread_deg']:.0f} deg)", (p["rho"], p["mission"]), fontsize=7,
                    xytext=(5, 4), textcoords="offset points")
    ax.set_xlabel(f"one view: Spearman of its utility with the realised {metric} gain (league)")
    ax.set_ylabel(f"ten views: mission {metric}, mean over steps and scenes")
    ax.set_title(f"from one view to a mission (marker size: view spread, {spreads.min():.0f}-{spreads.max():.0f} deg)",
                 fontsize=9)
    ax.grid(alpha=0.3)
    return ax
