"""The headroom instrument: does a planner's utility predict what a view will teach?

Introduced in notebook 08. From a seeded STAIR mission's state after K views, N candidate views spread
over the hemisphere (a Fibonacci set) are each added to a copy of the map, which is trained the same way
(the same training state and random stream, or another stream for the noise ceiling) and evaluated. A view's
realised gain is a metric after it minus the metric before it (for the chamfer distance, before minus after: a gain is
always an improvement). Every candidate is also scored by each measured planner's ``utility`` (by default every
registered planner that ranks views: STAIR's U of Eq. 15, Exploration's U_er of Eq. 12, Max View Distance's mean
squared camera distance, and the utilities beyond the paper), and each planner's own pick is realised the same way.
The spread of the gains is the headroom a planner has; the rank correlation (Spearman) of a utility with the gains
says whether the utility finds it; ``league`` compares the utilities over many tables against the noise ceiling.
"""
from __future__ import annotations

import copy
import csv
import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from .geometry import fibonacci_hemisphere, view_to_pose
from .maps import IMPLICIT, ImplicitMap
from .metrics import METRICS, compared_metrics
from .mission import Mission, MissionConfig
from .planners import PLANNERS, Planner, far_enough, make_planner
from .results_folder import make_output_folder, written_whole

FORMER_METRICS = ("psnr", "psnr_clean", "f1", "f1_5cm", "chamfer")  # the metrics of tables stored without a list
FORMER_UTILITIES = ("stair", "exploration", "max_distance")  # the utilities of tables stored without a list
MISSION_PLANNER = "stair"  # the planner of the seeded mission whose state the candidates start from


def ranking_planners() -> tuple[str, ...]:
    """The registered planners with a utility (``Planner.utility``) that read the field or no map: the league."""
    return tuple(name for name, r in PLANNERS.items()
                 if r.cls.utility is not Planner.utility and r.cls.reads in (None, IMPLICIT))


@dataclass
class Headroom:
    """What ``measure_headroom`` found: the metrics before the new view, one row per realised view (``kind``:
    "spread" for the spread candidates, else the planner whose pick it is; ``stream``: the training stream it was
    realised with, 0 the mission's own) and, per utility and metric, the Spearman rank correlation of the utility with
    the realised gain over the spread candidates (stream 0). With several streams, ``ceiling`` holds per metric how
    well the gains of one stream can be ranked by the others' mean gains: what any utility could reach."""

    scene: str
    after: int
    seed: int
    preset: str
    before: dict
    rows: list[dict]
    correlations: dict
    utilities: tuple[str, ...] = FORMER_UTILITIES
    streams: int = 1
    ceiling: dict | None = None
    metrics: tuple[str, ...] = FORMER_METRICS

    def gains(self, metric: str, kind: str = "spread", stream: int = 0) -> np.ndarray:
        return np.array([r[f"gain_{metric}"] for r in self.rows if r["kind"] == kind and int(r.get("stream", 0)) == stream])

    def pick_percentile(self, planner: str, metric: str) -> float:
        """The share of spread candidates whose gain is below that of ``planner``'s pick (1: better than all)."""
        (pick,) = self.gains(metric, planner)
        return float((self.gains(metric) < pick).mean())

    def best_share(self, planner: str, metric: str) -> float:
        """``planner``'s pick's gain as a share of the best spread candidate's gain (1: as good as the best)."""
        (pick,) = self.gains(metric, planner)
        best = self.gains(metric).max()
        return float(pick / best) if best > 0 else float("nan")

    def save(self, folder: str | Path, command: str = "") -> Path:
        """``<scene>_after<K>.csv`` (the rows) and ``.json`` (everything else) in ``folder``; returns the stem."""
        folder = make_output_folder(folder)
        stem = folder / f"{self.scene}_after{self.after}"
        with written_whole(stem.with_suffix(".csv")) as path, path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(self.rows[0]))
            writer.writeheader()
            writer.writerows(self.rows)
        summary = {k: v for k, v in asdict(self).items() if k != "rows"}
        summary["pick_percentiles"] = {p: {m: self.pick_percentile(p, m) for m in self.metrics} for p in self.utilities}
        summary["command"] = command
        with written_whole(stem.with_suffix(".json")) as path:
            path.write_text(json.dumps(summary, indent=1))
        return stem

    @classmethod
    def load(cls, stem: str | Path) -> "Headroom":
        stem = Path(stem)
        summary = json.loads(stem.with_suffix(".json").read_text())
        with stem.with_suffix(".csv").open() as f:
            rows = [{k: v if k == "kind" else float(v) for k, v in r.items()} for r in csv.DictReader(f)]
        optional = {k: summary[k] for k in ("streams", "ceiling") if k in summary}
        return cls(**{k: summary[k] for k in ("scene", "after", "seed", "preset", "before", "correlations")}, rows=rows,
                   utilities=tuple(summary.get("utilities", FORMER_UTILITIES)),
                   metrics=tuple(summary.get("metrics", FORMER_METRICS)), **optional)


class MapAfter:
    """A seeded mission (``MISSION_PLANNER``'s) after ``after`` views, and copies of its map that each add one more view:
    the same training state, and the same random stream (``stream`` 0) or another one (``stream`` k > 0)."""

    def __init__(self, scene: str, after: int, seed: int = 0, preset: str = "lite", device: str = "cpu"):
        self.mission = Mission(MissionConfig(scene=scene, planner=MISSION_PLANNER, seed=seed, preset=preset, budget=after),
                               device=device)
        self.mission.run()
        self.seed, self.device = seed, device
        self.visited, self.targets = np.array(self.mission.visited), self.mission.targets
        self.before = {m: self.mission.records[-1][m] for m in METRICS}
        self.state = self.mission.map.state_dict()
        self.measurements = [self.mission.simulator.render(view_to_pose(*v)) for v in self.visited]

    @property
    def field(self):
        return self.mission.map.planning_source

    def source_for(self, planner):
        """What ``planner`` reads of this mission's maps: the field, or nothing (a map-free planner)."""
        if planner.reads not in (None, self.mission.map.kind):
            raise ValueError(f"planner {planner.name!r} reads the {planner.reads} map, which a STAIR mission does not build; "
                             "the headroom instrument measures planners of the field or of no map")
        return self.field if planner.reads else None

    def planner(self, name: str):
        """The mission's own planner (its next view is the mission's), or a fresh one of another name."""
        if name == self.mission.config.planner:
            return self.mission.planner
        return make_planner(name, self.mission.preset, seed=self.seed + 1)

    def realise(self, view: np.ndarray, stream: int = 0) -> dict:
        """Every metric after adding ``view`` to a copy of the map and training it (training stream ``stream``)."""
        copy_of_map = ImplicitMap.from_preset(self.mission.preset, seed=self.seed, device=self.device)
        for m in self.measurements:
            copy_of_map.add_measurement(m)
        copy_of_map.load_state_dict(copy.deepcopy(self.state))
        if stream:
            copy_of_map.trainer.reseed(np.random.SeedSequence([self.seed, stream]).generate_state(1)[0])
        copy_of_map.integrate(self.mission.simulator.render(view_to_pose(*view)))
        result = self.mission.evaluator.evaluate(copy_of_map)
        return {name: metric.value(result, copy_of_map) for name, metric in METRICS.items()}


MAX_CANDIDATES, MAX_STREAMS = 128, 8  # 16 candidates x 3 streams take about 8 minutes at lite on one core


def check_headroom_size(after: int, n_candidates: int, streams: int) -> None:
    """Refuse a table that cannot be measured, or not in a day, naming the values."""
    if not (1 <= after and 2 <= n_candidates <= MAX_CANDIDATES and 1 <= streams <= MAX_STREAMS):
        raise ValueError(f"need at least 1 view before, 2 to {MAX_CANDIDATES} candidates and 1 to {MAX_STREAMS} streams, "
                         f"got after={after}, candidates={n_candidates}, streams={streams}")


def _finished_rows(path: Path | None, header: dict) -> dict:
    """The rows a stopped run of the same table left in ``path`` (one JSON line each after a header line), by job."""
    if path is None or not path.exists():
        return {}
    lines = path.read_text().splitlines()
    if not lines or json.loads(lines[0]) != header:
        raise ValueError(f"{path} holds the finished views of another headroom table; delete it to start anew")
    rows = {}
    for line in lines[1:]:
        try:
            job, row = json.loads(line)
        except ValueError:  # a line cut short by the interruption
            break
        rows[tuple(job)] = row
    return rows


def measure_headroom(scene: str, after: int, n_candidates: int, seed: int = 0, preset: str = "lite",
                     utilities: tuple[str, ...] | None = None, streams: int = 1, device: str = "cpu",
                     log=print, progress: Path | None = None) -> Headroom:
    """Run a seeded STAIR mission for ``after`` views, then realise ``n_candidates`` spread views (each with
    ``streams`` training streams) and the picks of the planners in ``utilities`` as the next view, each on a copy of
    the map (see the module). ``progress``: a file that keeps each realised view as it finishes, so that a stopped
    run continues where it stopped (the caller deletes it once the table is saved)."""
    check_headroom_size(after, n_candidates, streams)
    utilities = ranking_planners() if utilities is None else tuple(utilities)
    metrics = compared_metrics()
    state = MapAfter(scene, after, seed, preset, device)
    spread = fibonacci_hemisphere(n_candidates, azimuth_offset=np.random.default_rng(seed).uniform(0, 2 * np.pi))
    spread = spread[far_enough(spread, state.visited)]
    planners = {name: state.planner(name) for name in utilities}
    sources = {name: state.source_for(p) for name, p in planners.items()}
    picks = {name: p.next_view(sources[name], state.visited, state.targets).view for name, p in planners.items()}
    views = np.concatenate([spread, np.array([picks[p] for p in utilities])])
    scores = {name: p.utility(sources[name], views, state.visited, state.targets) for name, p in planners.items()}
    jobs = [(i, "spread", s) for s in range(streams) for i in range(len(spread))]
    jobs += [(len(spread) + j, name, 0) for j, name in enumerate(utilities)]
    header = {"scene": scene, "after": after, "seed": seed, "preset": preset, "candidates": n_candidates,
              "streams": streams, "utilities": list(utilities), "views": np.round(views, 9).tolist()}
    finished = _finished_rows(progress, header)
    if progress is not None and not finished:
        progress.write_text(json.dumps(header) + "\n")
    rows = []
    for n, (i, kind, stream) in enumerate(jobs):
        if (i, kind, stream) in finished:
            rows.append(finished[(i, kind, stream)])
            continue
        result = state.realise(views[i], stream)
        rows.append({"kind": kind, "stream": stream,
                     "elevation_deg": float(np.degrees(views[i][0])), "azimuth_deg": float(np.degrees(views[i][1])),
                     **{f"u_{u}": float(scores[u][i]) if scores[u] is not None else float("nan") for u in utilities},
                     **{m: float(result[m]) for m in metrics},
                     **{f"gain_{m}": METRICS[m].gain(state.before[m], float(result[m])) for m in metrics}})
        if progress is not None:
            with open(progress, "a") as f:
                f.write(json.dumps([[i, kind, stream], rows[-1]]) + "\n")
        log(f"{scene} after {after}: view {n + 1}/{len(jobs)} ({kind}, stream {stream}) F1 gain {rows[-1]['gain_f1']:+.3f}, "
            f"clean PSNR gain {rows[-1]['gain_psnr_clean']:+.2f} dB")
    before = {m: state.before[m] for m in metrics}
    result = Headroom(scene, after, seed, preset, before, rows, {}, tuple(utilities), streams, metrics=metrics)
    result.correlations = _correlations(result)
    if streams > 1:
        result.ceiling = {m: noise_ceiling(np.array([result.gains(m, stream=s) for s in range(streams)])) for m in metrics}
    return result


def table_state(result: Headroom, device: str = "cpu") -> MapAfter:
    """The map of ``result``'s seeded mission after its views, run again; refused when it no longer reaches the stored
    metrics (the code or the thread count changed), as then the table's gains are not this map's."""
    state = MapAfter(result.scene, result.after, result.seed, result.preset, device)
    # a relative 1e-7: float sums taken in another order move a PSNR by about 1e-8 dB; another map moves it by far more
    moved = {m: (result.before[m], state.before[m]) for m in result.metrics
             if not np.isclose(state.before[m], result.before[m], rtol=1e-7, atol=1e-9)}
    if moved:
        raise ValueError(f"{result.scene} after {result.after}: the seeded mission no longer reaches the table's state "
                         f"(stored and now: {moved}): the code or the thread count changed; measure the table anew "
                         "(--again)")
    return state


def add_utilities(result: Headroom, utilities: tuple[str, ...], device: str = "cpu", log=print) -> Headroom:
    """``result`` with more utilities measured on the same realised views: the mission is run again (it is seeded), each
    new planner's pick is realised (stream 0), and every utility scores every realised view again."""
    new = [u for u in utilities if u not in result.utilities]
    if not new:
        return result
    state = table_state(result, device)
    names = (*result.utilities, *new)
    planners = {name: state.planner(name) for name in names}
    rows = [dict(r) for r in result.rows]
    for name in new:
        view = planners[name].next_view(state.source_for(planners[name]), state.visited, state.targets).view
        realised = state.realise(view)
        rows.append({"kind": name, "stream": 0, "elevation_deg": float(np.degrees(view[0])),
                     "azimuth_deg": float(np.degrees(view[1])),
                     **{m: float(realised[m]) for m in result.metrics},
                     **{f"gain_{m}": METRICS[m].gain(result.before[m], float(realised[m])) for m in result.metrics}})
        log(f"{result.scene} after {result.after}: {name}'s pick realised, F1 gain {rows[-1]['gain_f1']:+.3f}")
    views = np.radians([[r["elevation_deg"], r["azimuth_deg"]] for r in rows])
    for name, p in planners.items():
        scores = p.utility(state.source_for(p), views, state.visited, state.targets)
        for r, score in zip(rows, scores):
            r[f"u_{name}"] = float(score)
    rows = [{k: r[k] for k in ("kind", "stream", "elevation_deg", "azimuth_deg", *(f"u_{u}" for u in names),
                               *result.metrics, *(f"gain_{m}" for m in result.metrics))} for r in rows]
    grown = Headroom(result.scene, result.after, result.seed, result.preset, result.before, rows, {}, names,
                     result.streams, result.ceiling, result.metrics)
    grown.correlations = _correlations(grown)
    return grown


def _correlations(result: Headroom) -> dict:
    """Per utility and metric, Spearman's correlation of the utility with the realised gain over the spread views of
    stream 0."""
    spread = [r for r in result.rows if r["kind"] == "spread" and int(r.get("stream", 0)) == 0]
    return {u: {m: rank_correlation([r[f"u_{u}"] for r in spread], [r[f"gain_{m}"] for r in spread])
                for m in result.metrics} for u in result.utilities}


def noise_ceiling(gains: np.ndarray) -> dict:
    """How well could any utility rank views whose realised gains ``gains`` (streams x views) vary with the training
    stream? Per stream, an oracle that knows the other streams' mean gain of each view: its Spearman correlation with
    this stream's gains and the share of views its pick beats in this stream; both averaged over the streams."""
    rhos, picks = [], []
    for s in range(len(gains)):
        oracle = np.delete(gains, s, axis=0).mean(axis=0)
        rhos.append(rank_correlation(oracle, gains[s]))
        picks.append(float((gains[s] < gains[s][np.argmax(oracle)]).mean()))
    rhos = [r for r in rhos if r is not None]
    return {"spearman": float(np.mean(rhos)) if rhos else None, "pick_percentile": float(np.mean(picks))}


def rank_correlation(a, b) -> float | None:
    """Spearman's rank correlation; None when either side does not vary or is missing (a planner that ranks nothing)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if not (np.isfinite(a).all() and np.isfinite(b).all()) or np.ptp(a) == 0 or np.ptp(b) == 0:
        return None
    return float(stats.spearmanr(a, b).statistic)


def print_headroom(result: Headroom, out=print) -> None:
    """A table per metric: the spread of the gains, and per utility its rank correlation and its pick's gain."""
    utilities = result.utilities
    out(f"{'metric':>10} {'spread of gains (min / median / max)':>38}" + "".join(f" {u[:12] + ' rho':>16}" for u in utilities)
        + "".join(f" {u[:12] + ' pick':>18}" for u in utilities))
    for m in result.metrics:
        g = result.gains(m)
        out(f"{m:>10} {g.min():12.4f} / {np.median(g):8.4f} / {g.max():8.4f}"
            + "".join(f" {result.correlations[u][m]:+16.2f}" if result.correlations[u][m] is not None else f" {'-':>16}"
                      for u in utilities)
            + "".join(f" {result.gains(m, u)[0]:+9.4f} ({result.pick_percentile(u, m):4.0%})" for u in utilities))
    if result.ceiling:
        out("noise ceiling (" + f"{result.streams} streams): " + ", ".join(
            f"{m} rho {c['spearman']:+.2f} pick {c['pick_percentile']:.0%}" for m, c in result.ceiling.items()
            if c["spearman"] is not None))
    out("(pick: its gain, and the share of spread candidates it beats)")


def league(tables: list[Headroom]) -> list[dict]:
    """Per utility and metric over headroom tables: the mean pick percentile, the mean Spearman correlation with the
    realised gain and the mean share of the best candidate's gain that the pick realises; and the noise ceiling
    (utility "ceiling", from the tables realised with several streams)."""
    rows = []
    utilities = list(dict.fromkeys(u for t in tables for u in t.utilities))
    metrics = [m for m in dict.fromkeys(m for t in tables for m in t.metrics) if all(m in t.metrics for t in tables)]
    for u in utilities:
        mine = [t for t in tables if u in t.utilities]
        for m in metrics:
            rhos = [t.correlations[u][m] for t in mine if t.correlations[u][m] is not None]
            shares = [t.best_share(u, m) for t in mine]
            rows.append({"utility": u, "metric": m, "tables": len(mine),
                         "pick_percentile": float(np.mean([t.pick_percentile(u, m) for t in mine])),
                         "spearman": float(np.mean(rhos)) if rhos else float("nan"),
                         "best_share": float(np.nanmean(shares)) if np.isfinite(shares).any() else float("nan")})
    noisy = [t for t in tables if t.ceiling]
    for m in metrics if noisy else ():
        rhos = [t.ceiling[m]["spearman"] for t in noisy if t.ceiling[m]["spearman"] is not None]
        rows.append({"utility": "ceiling", "metric": m, "tables": len(noisy),
                     "pick_percentile": float(np.mean([t.ceiling[m]["pick_percentile"] for t in noisy])),
                     "spearman": float(np.mean(rhos)) if rhos else float("nan"), "best_share": float("nan")})
    return rows


def league_markdown(tables: list[Headroom]) -> str:
    """The league as a Markdown table, a row per utility and metric."""
    lines = [f"{len(tables)} headroom tables ({', '.join(sorted(f'{t.scene}@{t.after}' for t in tables))}); pick: the share "
             "of spread candidates the utility's own pick beats; rho: Spearman with the realised gain over the spread "
             "candidates; share: the pick's gain over the best candidate's; ceiling: an oracle that knows the mean gain "
             "of the other training streams", "",
             "| utility | metric | tables | pick | rho | share |", "|---|---|---|---|---|---|"]
    for r in league(tables):
        share = "-" if not np.isfinite(r["best_share"]) else f"{r['best_share']:+.2f}"
        lines.append(f"| {r['utility']} | {r['metric']} | {r['tables']} | {r['pick_percentile']:.0%} | {r['spearman']:+.2f} "
                     f"| {share} |")
    return "\n".join(lines)
