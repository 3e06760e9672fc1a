"""Experiment sweeps (paper Sec. IV): scenes x planner variants x seeds, one mission per cell.

Introduced in notebook 06. Each cell writes its own folder ``<out>/<scene>/<variant>/seed<k>/`` (the
mission's metrics.json and checkpoint), so a finished cell is never recomputed and killing a sweep
loses nothing finished. Cells run in this process, or on a Dask cluster (a local one of single-threaded
worker processes, or an existing one): ``run_sweep``. ``collect`` gathers every finished cell into one table, a row per
(scene, variant, seed, step).

Variants: the planners (stair, exploration, fixed, max_distance, uniform), ``ste`` (the explicit
baseline, evaluated on its voxel map), the paper's cross-validation ``stair_explicit`` (STAIR's views
fused into the explicit map) and ``ste_implicit`` (STE's views used to train the field), and
``stair_eps<value>`` (STAIR with another exploration weight, for the ablation).
"""
from __future__ import annotations

import csv
import json
import os
import time
import uuid
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .config import check_epsilon, get_preset
from .maps import EXPLICIT, IMPLICIT
from .metrics import METRICS
from .mission import Mission, MissionConfig
from .planners import PLANNERS, REPLAY, is_planner_file, paper_planners, planner_class, planner_file_hash
from .results_folder import (FORMAT, METRICS_FILE, FolderInUseError, ResultsFolderError, make_output_folder,
                             source_hash, upgrade_header, write_json_atomically)
from .scenes import scene_content_hash, scene_key, scene_path
from .segmenter import EXACT, label_noise

PAPER_SCENES = ("scene1", "scene2", "scene3", "scene4")
SWEEP_FILE = "sweep.json"
CONNECT_TIMEOUT_S = 20  # to reach a scheduler (an address that is no Dask scheduler answers nothing, or nonsense)
WORKER_TIMEOUT_S = 300  # how long a sweep waits for a worker when its cluster has none
RESULTS_DIR = Path(__file__).resolve().parent.parent / "data" / "results"  # the stored sweeps


def score_columns() -> tuple[str, ...]:
    """The score columns of every registered planner, each once, in registration order."""
    return tuple(dict.fromkeys(c for r in PLANNERS.values() for c in r.cls.score_columns))


def table_columns(extra_scores: tuple[str, ...] = ()) -> tuple[str, ...]:
    """The results table's columns: the cell, every registered metric, the planners' scores (and ``extra_scores``, a
    researcher's planner's own), the loss, the view and the phases' times."""
    return ("scene", "variant", "seed", "step", *METRICS, *dict.fromkeys((*score_columns(), *extra_scores)), "loss",
            "elevation_deg", "azimuth_deg", "time_plan_s", "time_train_s", "time_evaluate_s")

EPSILON_PREFIX = "stair_eps"


@dataclass(frozen=True)
class Variant:
    """What a sweep variant runs: a planner, the map that is evaluated (None: the planner's own map, else
    the field), the variant whose views it follows (the paper's cross-validation) and an exploration
    weight (None: the preset's)."""

    name: str
    planner: str
    mapper: str | None = None
    replays: str | None = None
    epsilon: float | None = None


# The paper's cross-validation: one planner's views evaluated on the other map.
CROSS_VALIDATION_VARIANTS = {"stair_explicit": Variant("stair_explicit", REPLAY, EXPLICIT, replays="stair"),
                             "ste_implicit": Variant("ste_implicit", REPLAY, IMPLICIT, replays="ste")}
CROSS_VALIDATION = {v.name: v.replays for v in CROSS_VALIDATION_VARIANTS.values()}  # variant -> the variant it replays


def base_variants() -> tuple[str, ...]:
    """The paper's planners (a sweep's "base")."""
    return paper_planners()


def all_variants() -> tuple[str, ...]:
    """The paper's comparison ("all"): its planners and the cross-validation; the others are named."""
    return (*paper_planners(), *CROSS_VALIDATION)


def variant_key(name: str) -> str:
    """The folder name of a variant: its name, or for ``path/to/file.py:ClassName`` the file's stem and the class."""
    if is_planner_file(name):
        path, _, cls = name.rpartition(":")
        return f"{Path(path).stem}.{cls}"
    return name


@dataclass(frozen=True)
class Cell:
    scene: str
    variant: str
    seed: int

    def folder(self, root: Path) -> Path:
        return Path(root) / scene_key(self.scene) / variant_key(self.variant) / f"seed{self.seed}"

    def steps(self, root: Path) -> list[dict]:
        """The stored step records of this cell under ``root``."""
        return json.loads((self.folder(root) / METRICS_FILE).read_text())["steps"]


def epsilon_of(name: str) -> float:
    """The exploration weight of a ``stair_eps<value>`` variant."""
    return float(name[len(EPSILON_PREFIX):])


def variant(name: str) -> Variant:
    """The variant of a name: a registered planner, a cross-validation variant, ``stair_eps<non-negative number>``
    (STAIR with that epsilon) or a researcher's planner ``path/to/file.py:ClassName``."""
    if name in PLANNERS:
        return Variant(name, name)
    if name in CROSS_VALIDATION_VARIANTS:
        return CROSS_VALIDATION_VARIANTS[name]
    if is_planner_file(name):
        planner_class(name)  # loads it: a missing file or class is named now, not in a worker
        return Variant(name, name)
    if name.startswith(EPSILON_PREFIX):
        try:
            epsilon = epsilon_of(name)
        except ValueError:
            epsilon = None  # not a number: an unknown variant
        if epsilon is not None:
            try:
                check_epsilon(epsilon)
            except ValueError as err:
                raise ValueError(f"planner variant {name!r}: {err}") from None
            return Variant(name, "stair", epsilon=epsilon)
    raise ValueError(f"unknown planner variant {name!r}; choose from {', '.join((*PLANNERS, *CROSS_VALIDATION))}, "
                     f"{EPSILON_PREFIX}<value> or path/to/file.py:ClassName")


def mission_config(cell: Cell, root: Path, preset: str, budget: int | None = None,
                   label_noise: str = EXACT) -> MissionConfig:
    """The mission a cell runs."""
    v = variant(cell.variant)
    replay = str(Cell(cell.scene, v.replays, cell.seed).folder(root) / METRICS_FILE) if v.replays else None
    return MissionConfig(scene=cell.scene, planner=v.planner, seed=cell.seed, preset=preset, budget=budget,
                         epsilon=v.epsilon, mapper=v.mapper, replay=replay, label_noise=label_noise)


def cell_state(cell: Cell, root: Path, budget: int) -> str:
    """'done', 'partial', 'missing' or 'corrupt' (an unreadable metrics file)."""
    path = cell.folder(root) / METRICS_FILE
    if not path.exists():
        return "missing"
    try:
        steps = json.loads(path.read_text()).get("steps", [])
    except (json.JSONDecodeError, UnicodeDecodeError, AttributeError):
        return "corrupt"
    if not isinstance(steps, list) or not all(isinstance(r, dict) for r in steps):
        return "corrupt"  # e.g. {"steps": 5}
    return "done" if len(steps) >= budget else "partial"


def run_cell(cell: Cell, root: str, preset: str, budget: int, threads: int | None = None,
             device: str = "cpu", label_noise: str = EXACT) -> tuple[Cell, str]:
    """Run (or resume) one cell with ``threads`` torch threads (None: as the process is set; the thread count is
    restored after) and the segmenter's ``label_noise``; a corrupt or unresumable cell is redone from scratch."""
    import torch

    previous = torch.get_num_threads()
    if threads:
        torch.set_num_threads(threads)
    root = Path(root)
    config = mission_config(cell, root, preset, budget, label_noise)
    state = cell_state(cell, root, budget)
    try:
        Mission(config, out=cell.folder(root), resume=state == "partial", overwrite=state == "corrupt", device=device).run()
        return cell, "redone (was corrupt)" if state == "corrupt" else "ran"
    except FolderInUseError:  # another process runs this cell (an earlier sweep's worker): never race it
        raise
    except ResultsFolderError as err:  # an unusable partial result: start the cell again
        Mission(config, out=cell.folder(root), overwrite=True, device=device).run()
        return cell, f"redone ({err})"
    finally:
        torch.set_num_threads(previous)


@dataclass(frozen=True)
class SweepSpec:
    scenes: tuple[str, ...]
    variants: tuple[str, ...]
    seeds: tuple[int, ...]
    preset: str = "lite"
    budget: int | None = None  # None: the preset's
    label_noise: str = EXACT  # the segmenter's noise level in every cell (segmenter.py)

    def __post_init__(self):
        label_noise(self.label_noise)
        for scene in self.scenes:
            scene_path(scene)  # a shipped name or a regular scene file of sane size, else the reason
        keys = [scene_key(s) for s in self.scenes]
        if len(set(keys)) < len(keys):
            raise ValueError(f"two scenes of {list(self.scenes)} would share a results folder (a scene file is stored "
                             "under its name without .json): rename one")
        for v in self.variants:
            variant(v)
        keys = [variant_key(v) for v in self.variants]
        if len(set(keys)) < len(keys):
            raise ValueError(f"two planners of {list(self.variants)} would share a results folder (a planner file's cells "
                             "are stored under its file's stem and class name): rename one")
        if not self.seeds or min(self.seeds) < 0:
            raise ValueError(f"seeds must be non-negative, got {list(self.seeds)}")
        preset = get_preset(self.preset)
        object.__setattr__(self, "budget", preset.budget if self.budget is None else self.budget)
        preset.with_budget(self.budget)  # checks it

    def cells(self) -> list[Cell]:
        """All cells, seed by seed (a partial sweep covers every scene and variant); within a seed the
        cross-validation ones last (they replay other cells' views)."""
        ordered = sorted(self.variants, key=lambda v: variant(v).replays is not None)
        return sorted((Cell(s, v, k) for v in ordered for s in self.scenes for k in self.seeds),
                      key=lambda c: (c.seed, variant(c.variant).replays is not None))


# How closely a stored cell reproduces elsewhere. One machine at one torch thread count reproduces a
# mission exactly; another CPU rounds some float sums differently, and training amplifies that.
# Replaying the views of scene1/stair/seed0 on two x86-64 CPUs gave PSNR within 1e-4 dB after the first
# view, 0.16 dB after three and 0.41 dB after ten (F1: 0.011 after three, 0.11 after ten). When two
# candidate views score almost the same, such a difference can also flip the planner's choice.
REPRODUCTION_TOLERANCE = {"psnr_first_step": 0.01, "psnr": 0.5, "f1": 0.05}  # for a mission's first three steps


def reproduction_gaps(stored: list[dict], live: list[dict]) -> list[dict]:
    """Per step of ``live``: whether its view is the stored one (to 1e-9 rad) and the PSNR and F1 differences."""
    return [{"step": new["step"], "same_view": bool(np.allclose(new["view_rad"], old["view_rad"], rtol=0, atol=1e-9)),
             "psnr": abs(new["psnr"] - old["psnr"]), "f1": abs(new["f1"] - old["f1"])} for old, new in zip(stored, live)]


def check_sweep_folder(root: Path, spec: SweepSpec, log=print) -> None:
    """Refuse a folder written by a sweep with another preset or budget (results must not mix); warn
    when the package's code has changed since the folder's first cells were run."""
    make_output_folder(root)
    path = root / SWEEP_FILE
    mine = {"preset": spec.preset, "budget": spec.budget, "preset_values": asdict(get_preset(spec.preset)),
            "label_noise": spec.label_noise}
    files = {scene_key(s): scene_content_hash(s) for s in spec.scenes}  # shipped scenes too: a file may share a name
    planner_files = {variant_key(v): planner_file_hash(v) for v in spec.variants if is_planner_file(v)}
    if path.exists():
        try:
            stored = upgrade_header(json.loads(path.read_text()))
            stored_files = dict(stored.get("scene_files", {}))
            stored_planner_files = dict(stored.get("planner_files", {}))
        except (json.JSONDecodeError, UnicodeDecodeError, AttributeError, TypeError, ValueError) as err:
            raise ValueError(f"{path} is unreadable ({err}); restore it, or use another folder") from None
        if {k: stored.get(k) for k in mine} != json.loads(json.dumps(mine)):
            raise ValueError(f"{root} holds results of a sweep with preset {stored.get('preset')!r}, budget "
                             f"{stored.get('budget')} and label noise {stored.get('label_noise')!r}; use another folder "
                             f"for preset {spec.preset!r}, budget {spec.budget}, label noise {spec.label_noise!r}")
        changed = sorted(k for k in files if k in stored_files and stored_files[k] != files[k])
        if changed:
            details = ", ".join(f"{k}: {stored_files[k]} there, {files[k]} now" for k in changed)
            raise ValueError(f"{root} holds results of other scenes named {changed} (scene content {details}): a scene "
                             "file was edited, or shares its name with another scene; restore it or use another folder")
        changed = sorted(k for k in planner_files if k in stored_planner_files and stored_planner_files[k] != planner_files[k])
        if changed:
            details = ", ".join(f"{k}: {stored_planner_files[k]} there, {planner_files[k]} now" for k in changed)
            raise ValueError(f"{root} holds results of planner files {changed} whose content has changed ({details}): "
                             "restore the file, or use another folder")
        if stored.get("source_hash") != source_hash():
            log(f"warning: {root} was started with stair_lite sources {stored.get('source_hash')}, these are "
                f"{source_hash()}: finished cells are kept; delete them to recompute with this code")
        if set(files) - set(stored_files) or set(planner_files) - set(stored_planner_files):
            write_json_atomically(path, {**stored, "scene_files": {**stored_files, **files},
                                         "planner_files": {**stored_planner_files, **planner_files}})
    else:
        write_json_atomically(path, {"format": FORMAT, **mine, "source_hash": source_hash(), "scene_files": files,
                                     "planner_files": planner_files})


def replay_source(cell: Cell) -> Cell | None:
    """The cell whose views a cross-validation cell replays (None for every other cell)."""
    replays = variant(cell.variant).replays
    return Cell(cell.scene, replays, cell.seed) if replays else None


def run_sweep(spec: SweepSpec, root: str | Path, workers: int = 1, progress: bool = True, log=print,
              device: str = "cpu", scheduler: str | None = None,
              worker_timeout_s: float = WORKER_TIMEOUT_S) -> list[tuple[Cell, str]]:
    """Run every unfinished cell, each mission on ``device``; returns what happened to each cell.

    ``workers`` <= 1 and no ``scheduler``: one cell after another in this process. ``workers`` N > 1: on a
    local Dask cluster of N single-threaded worker processes, started and stopped here. ``scheduler``
    (an address such as ``tcp://host:8786``): on an existing Dask cluster. A cross-validation cell starts
    as soon as the cell it replays has finished, so a sweep stopped early holds whole seeds of every
    variant. A cell whose worker dies or raises is reported as failed and redone by the next run."""
    from tqdm import tqdm

    root = Path(root)
    check_sweep_folder(root, spec, log)
    cells = spec.cells()
    states = {c: cell_state(c, root, spec.budget) for c in cells}  # read every metrics file once
    finished = {c for c in cells if states[c] == "done"}
    for c in cells:
        if states[c] == "corrupt":
            log(f"corrupt results in {c.folder(root)}: the cell will be redone")
        source = replay_source(c)
        if source and source not in states:  # replays a cell this sweep does not run: it must be on disk
            if cell_state(source, root, spec.budget) != "done":
                raise ValueError(f"{c.variant} replays the views of {source.variant}, which this sweep neither runs "
                                 f"nor finds finished in {source.folder(root)}; add {source.variant} to the planners")
            finished.add(source)
    outcomes = [(c, "finished before") for c in cells if states[c] == "done"]
    waiting = [c for c in cells if states[c] != "done"]

    def release() -> Cell | None:
        """The first unfinished cell in sweep order whose replay source (if any) has finished (None: none is ready), so
        a cross-validation cell runs before later seeds' cells once the cell it replays has finished."""
        ready = next((c for c in waiting if replay_source(c) is None or replay_source(c) in finished), None)
        if ready is not None:
            waiting.remove(ready)
        return ready

    bar = tqdm(total=len(cells), initial=len(outcomes), desc="cells", unit="cell", disable=not progress)

    def done(outcome: tuple[Cell, str]) -> None:
        outcomes.append(outcome)
        if not outcome[1].startswith("failed"):
            finished.add(outcome[0])
        bar.update(1)

    try:
        if workers <= 1 and scheduler is None:
            while (c := release()) is not None:  # one torch thread, as a cluster's workers: float sums depend on it
                try:
                    done(run_cell(c, str(root), spec.preset, spec.budget, 1, device, spec.label_noise))
                except Exception as err:  # as on a cluster: the cell is reported, the others run
                    done((c, f"failed ({type(err).__name__}: {err}); run the sweep again to redo it"))
        else:
            with dask_client(workers, scheduler) as client:
                run_on_cluster(client, release, done, root, spec, device, log, worker_timeout_s)
    finally:
        bar.close()
    outcomes += [(c, f"not run: the cell it replays ({replay_source(c).variant}) failed") for c in waiting]
    return outcomes


class ClusterError(ValueError):
    """The Dask cluster cannot run the sweep's cells: no scheduler at the address, no workers, or the scheduler lost."""


class dask_client:
    """A Dask client: of the cluster at ``scheduler``, or of a local cluster of ``workers`` single-threaded
    worker processes that lives as long as the client. A worker that dies fails its task at once (no
    retry on another worker), so its cell is reported and redone by the next run."""

    def __init__(self, workers: int, scheduler: str | None = None):
        self.workers, self.scheduler = workers, scheduler

    def __enter__(self):
        import logging

        import dask
        from dask.distributed import Client, LocalCluster

        self.cluster, self.environ = None, dict(os.environ)
        # Dask logs its own tracebacks when a scheduler misbehaves or goes away; the sweep says it in one line instead
        logging.getLogger("distributed").setLevel(logging.CRITICAL)
        with dask.config.set({"distributed.scheduler.allowed-failures": 0,
                              "distributed.comm.timeouts.connect": f"{CONNECT_TIMEOUT_S}s"}):
            if self.scheduler is None:
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                            dashboard_address=":0", silence_logs=logging.ERROR)
                self.client = Client(self.cluster)
            else:
                self.client = _connect(Client, self.scheduler)
        if self.cluster is not None:
            self.client.run(_quiet_worker)
        self._restore_environment()
        return self.client

    def __exit__(self, *exc):
        import contextlib

        with contextlib.suppress(Exception):  # a scheduler that is gone cannot be told goodbye
            self.client.close(timeout=5)
        if self.cluster is not None:
            self.cluster.close()  # stops the worker processes, also on Ctrl-C
        self._restore_environment()

    def _restore_environment(self) -> None:
        """Starting workers sets OMP_NUM_THREADS=1 (and the like) in this process's environment too;
        undo it, or every process started from here later (a notebook kernel) runs on one thread."""
        os.environ.clear()
        os.environ.update(self.environ)


def _connect(client_class, address: str):
    """A client of the scheduler at ``address``, or ``ClusterError`` within ``CONNECT_TIMEOUT_S``: Dask's own timeout
    does not hold against a server that accepts and never answers, or answers another protocol (HTTP), so the
    connection is made in a thread that is given up on."""
    import threading

    outcome = {}

    def connect():
        try:
            outcome["client"] = client_class(address, timeout=CONNECT_TIMEOUT_S)
        except BaseException as err:  # refused, or not speaking Dask's protocol (then any error at all)
            outcome["error"] = err

    thread = threading.Thread(target=connect, daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT_S + 1)
    if "client" in outcome:
        return outcome["client"]
    err = outcome.get("error")
    why = f"{type(err).__name__}: {str(err)[:160]}" if err is not None else "no answer"
    raise ClusterError(f"no Dask scheduler answers at {address} within {CONNECT_TIMEOUT_S} s ({why}); start one with "
                       "`dask scheduler` and give its address, tcp://host:8786")


def _quiet_worker() -> None:
    """Run on a local cluster's workers. Ctrl-C reaches every process of the terminal's group, but the sweep's
    own process stops the workers, so they ignore it. And a worker's own log is silenced: a cell that fails
    comes back to the sweep with its exception, while a worker whose sweep was killed (SIGKILL) would only
    log tracebacks about the scheduler it lost before it exits."""
    import logging
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed").setLevel(logging.CRITICAL)


def _threads(client, address) -> int:
    """The cluster's worker threads now (a scheduler that is gone: ``ClusterError``)."""
    try:
        return sum(client.nthreads().values())
    except Exception as err:
        raise ClusterError(f"lost the Dask scheduler at {address} ({type(err).__name__}); the finished cells are kept, "
                           "run the sweep again once it is back") from None


def run_on_cluster(client, release, done, root: Path, spec: SweepSpec, device: str, log=print,
                   worker_timeout_s: float = WORKER_TIMEOUT_S) -> None:
    """Submit released cells to the cluster and collect them as they finish (see ``run_sweep``). No more
    cells are in flight than the cluster has worker threads, so a worker holds only the cell it runs and
    a dead worker fails that one cell. A cluster without workers is waited for ``worker_timeout_s`` (said once),
    then given up with ``ClusterError``."""
    from dask.distributed import as_completed

    address = client.scheduler.address
    cell_of, queue = {}, as_completed()
    without_workers = None  # since when the cluster has had no worker

    def fill(threads: int) -> None:
        for _ in range(threads - queue.count()):
            c = release()
            if c is None:
                return
            future = client.submit(run_cell, c, str(root), spec.preset, spec.budget, 1, device, spec.label_noise, pure=False,
                                   key=f"{c.scene}-{c.variant}-seed{c.seed}-{uuid.uuid4().hex[:8]}")
            cell_of[future] = c
            queue.add(future)

    while True:
        threads = _threads(client, address)
        if threads:
            without_workers = None
            fill(threads)
        elif without_workers is None:
            without_workers = time.monotonic()
            log(f"waiting for a worker: the Dask cluster at {address} has none (giving up after {worker_timeout_s:.0f} s)")
        elif time.monotonic() - without_workers > worker_timeout_s:
            raise ClusterError(f"the Dask cluster at {address} has had no worker for {worker_timeout_s:.0f} s; start "
                               f"workers (`dask worker {address} --nthreads 1`) and run the sweep again: the finished "
                               "cells are kept")
        if queue.is_empty():
            if threads:
                return  # nothing left to release
            time.sleep(0.5)
            continue
        for future in queue.next_batch(block=False) if queue.has_ready() else ():
            try:
                outcome = future.result()
            except Exception as err:  # the cell raised, or its worker died (KilledWorker)
                outcome = (cell_of[future], f"failed ({type(err).__name__}: {err}); run the sweep again to redo it")
            done(outcome)
        time.sleep(0.2)


def _folder_study(root: Path) -> dict | None:
    """What a results folder's cells must share (preset, label noise): its sweep.json's, else None (the first cell
    then sets it)."""
    sweep_file = root / SWEEP_FILE
    if not sweep_file.exists():
        return None
    try:
        stored = json.loads(sweep_file.read_text())
        return {"budget": int(stored["budget"]), "preset": stored["preset"], "label_noise": stored.get("label_noise", EXACT)}
    except (ValueError, KeyError, TypeError) as err:
        raise ValueError(f"{sweep_file} is unreadable ({type(err).__name__}: {err}); restore it from the repository "
                         "or delete it (then the first finished cell sets the folder's preset)") from None


def collect(root: str | Path, log=print) -> list[dict]:
    """One row per (scene, variant, seed, step) from every finished, readable cell under ``root`` (a cell still
    running, with fewer steps than the sweep's budget, is left out). Cells of another preset or label noise than
    the folder's (its sweep.json, else its first cell) are reported and left out: a study never mixes them."""
    rows = []
    root = Path(root)
    study = _folder_study(root)
    for path in sorted(root.glob(f"*/*/seed*/{METRICS_FILE}")):
        scene, variant_name, seed = path.parts[-4], path.parts[-3], int(path.parts[-2][4:])
        try:
            stored = json.loads(path.read_text())
            config, steps = stored["config"], stored["steps"]
            mine = {"preset": config["preset"], "label_noise": config.get("label_noise", EXACT)}
            if study is None:
                study = {"budget": len(steps), **mine}
                log(f"{root} has no {SWEEP_FILE}: its cells must share the first one's preset {mine['preset']} and "
                    f"label noise {mine['label_noise']}")
            mixed = [f"{k} {mine[k]} (the folder's: {study[k]})" for k in mine if mine[k] != study[k]]
            if mixed:
                log(f"skipping {path}: another study's mission, {', '.join(mixed)}")
                continue
            if len(steps) < study["budget"]:
                log(f"skipping unfinished {path} ({len(steps)} of {study['budget']} steps)")
                continue
            planner = config.get("planner", "")
            scores = PLANNERS[planner].cls.score_columns if planner in PLANNERS else score_columns()
            cell_rows = [{
                "scene": scene, "variant": variant_name, "seed": seed, "step": r["step"],
                **{k: r.get(k) for k in METRICS}, "loss": r["loss"],  # a metric registered after the mission ran: None
                **{k: r.get(k) for k in scores},
                "elevation_deg": r["view_deg"][0], "azimuth_deg": r["view_deg"][1],
                "time_plan_s": r["time_s"]["plan"], "time_train_s": r["time_s"]["train"],
                "time_evaluate_s": r["time_s"]["evaluate"],
            } for r in steps]
        except (ValueError, KeyError, TypeError, IndexError, UnicodeDecodeError) as err:  # not a mission's records
            log(f"skipping unreadable {path}: {type(err).__name__}: {err}")
            continue
        rows += cell_rows
    return rows


def write_table(rows: list[dict], path: str | Path) -> Path:
    path = Path(path)
    known = table_columns()
    extra = tuple(dict.fromkeys(k for r in rows for k in r if k not in known))
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=table_columns(extra))
        writer.writeheader()
        writer.writerows(rows)
    return path


def read_table(path: str | Path) -> list[dict]:
    """Read a results CSV back, with numbers as floats (empty cells as None)."""
    with Path(path).open() as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            if k not in ("scene", "variant"):
                r[k] = None if v == "" else float(v)
    return rows


def curves(rows: list[dict], metric: str) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray, np.ndarray, int]]:
    """(scene, variant) -> (steps, mean, std over seeds, number of seeds) of a metric against the step."""
    out = {}
    for key in sorted({(r["scene"], r["variant"]) for r in rows}):
        sel = [r for r in rows if (r["scene"], r["variant"]) == key]
        steps = np.array(sorted({int(r["step"]) for r in sel}))
        values = [[r[metric] for r in sel if int(r["step"]) == s] for s in steps]
        out[key] = (steps, np.array([np.mean(v) for v in values]), np.array([np.std(v) for v in values]),
                    len({r["seed"] for r in sel}))
    return out


def summary(rows: list[dict], metrics=("psnr", "f1")) -> list[dict]:
    """Per (scene, variant): mean +- std over seeds of each metric's area under the curve (mean over
    steps) and of its final-step value."""
    table = []
    for scene, variant in sorted({(r["scene"], r["variant"]) for r in rows}):
        sel = [r for r in rows if (r["scene"], r["variant"]) == (scene, variant)]
        entry = {"scene": scene, "variant": variant, "seeds": len({r["seed"] for r in sel})}
        for m in metrics:
            per_seed_auc, per_seed_final = [], []
            for seed in sorted({r["seed"] for r in sel}):
                mine = sorted((r for r in sel if r["seed"] == seed), key=lambda r: r["step"])
                per_seed_auc.append(np.mean([r[m] for r in mine]))
                per_seed_final.append(mine[-1][m])
            entry[f"{m}_auc_mean"], entry[f"{m}_auc_std"] = float(np.mean(per_seed_auc)), float(np.std(per_seed_auc))
            entry[f"{m}_final_mean"], entry[f"{m}_final_std"] = float(np.mean(per_seed_final)), float(np.std(per_seed_final))
        table.append(entry)
    return table
