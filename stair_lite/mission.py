"""The active reconstruction mission (paper Sec. IV): measure at the top view, then repeat
{train, evaluate, plan, move, measure} until the budget of measurements is spent.

Introduced in notebook 05. After every measurement the mission records the view, the planner's
scores, the training loss, target-only PSNR and target-mesh precision / completeness / F1 and the
wall time of each phase, and writes them to ``metrics.json`` (atomically replaced) together with a
checkpoint that holds the same records, so an interrupted mission loses nothing finished and can be resumed
exactly. One process at a time writes to a results folder (a lock file); ``--overwrite`` replaces the old
results only when the new mission saves its first step.
"""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from .allocator import release_freed_memory
from .classes import CLASS_NAMES
from .config import Preset, check_device, get_preset
from .evaluation import Evaluator, f1_column
from .explicit import ExplicitMap
from .geometry import TOP_VIEW, view_to_pose
from .maps import IMPLICIT, MAP_KINDS, ImplicitMap, ReconstructionMap
from .planners import make_planner, planner_class
from .scenes import load_scene, scene_file_hash
from .segmenter import EXACT, NoisySegmenter, label_noise
from .simulator import Simulator

METRICS_FILE, CHECKPOINT_FILE, LOCK_FILE = "metrics.json", "checkpoint.pt", ".lock"
MAP_CLASSES = {cls.kind: cls for cls in (ImplicitMap, ExplicitMap)}
SCORE_COLUMNS = ("utility", "exploitation", "exploration", "ste_utility")  # a record's planner scores (None if absent)


@dataclass(frozen=True)
class MissionConfig:
    """What defines a mission; two runs with equal configs give the same trajectory and metrics.

    ``budget`` and ``epsilon`` left at None take the preset's; ``mapper`` (the map that is evaluated)
    left at None is the map the planner reads, else the field. After construction all three hold
    the values the mission runs with, so a stored header records them.
    """

    scene: str = "scene1"
    planner: str = "stair"
    seed: int = 0
    preset: str = "lite"
    targets: tuple[str, ...] | None = None  # None: the scene's own targets
    budget: int | None = None
    epsilon: float | None = None
    mapper: str | None = None  # "implicit" (the field) or "explicit" (STE's voxel map)
    replay: str | None = None  # with planner "replay": a metrics.json whose views are followed
    label_noise: str = EXACT  # the segmenter's noise level (segmenter.py; the evaluation stays exact)

    def __post_init__(self):
        cls = planner_class(self.planner, self.replay)
        if self.mapper is not None and self.mapper not in MAP_KINDS:
            raise ValueError(f"unknown mapper {self.mapper!r}; choose one of {', '.join(MAP_KINDS)}")
        label_noise(self.label_noise)  # checks the level's name
        if not 0 <= self.seed < 2**32:
            raise ValueError(f"seed must be a whole number from 0 to 2**32 - 1, got {self.seed!r}")
        preset = get_preset(self.preset)
        resolved = {"budget": preset.budget if self.budget is None else self.budget,
                    "epsilon": preset.plan.epsilon if self.epsilon is None else self.epsilon,
                    "mapper": self.mapper or cls.reads or IMPLICIT}
        for name, value in resolved.items():
            object.__setattr__(self, name, value)
        self.apply(preset)  # checks budget and epsilon

    def apply(self, preset: Preset) -> Preset:
        """``preset`` with this mission's budget and exploration weight."""
        return preset.with_budget(self.budget).with_epsilon(self.epsilon)


def make_output_folder(folder: str | Path) -> Path:
    """Create a folder for results (and its parents), or refuse in one line that names the problem: a file where
    a folder belongs, or a folder that cannot be written. Commands call it before they compute anything."""
    folder = Path(folder)
    blocking = next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise OSError(f"cannot write results into {folder}: {blocking} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OSError(f"cannot create the folder {folder}: {err.strerror or err}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OSError(f"cannot write into the folder {folder}: it is read-only")
    return folder


def write_json_atomically(path: Path, data) -> None:
    """Write JSON to a temporary file, then rename it over ``path``: readers never see a partial file. A score
    that is not a finite number (the PSNR of a perfect image) is written as null: NaN is not JSON."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    try:
        tmp.write_text(json.dumps(_finite_or_null(data), indent=1, allow_nan=False))
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise OSError(f"could not write {path}: {err.strerror or err}") from None
    os.replace(tmp, path)


def _finite_or_null(value):
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(v) for v in value]
    return value


def _differences(stored, mine, where: str = "") -> list[str]:
    """Where two mission headers differ, as "field: stored there X, now Y" (a config without ``label_noise`` was
    written before noisy labels existed, or by an exact mission: its level is none)."""
    if isinstance(stored, dict) and isinstance(mine, dict):
        if where == "config":
            stored, mine = {"label_noise": EXACT, **stored}, {"label_noise": EXACT, **mine}
        return [line for key in sorted(set(stored) | set(mine), key=str)
                for line in _differences(stored.get(key), mine.get(key), f"{where}.{key}" if where else key)]
    return [] if stored == mine else [f"{where}: {stored!r} there, {mine!r} now"]


def _steps_and_views(records: list[dict]) -> list[tuple]:
    return [(r["step"], r["view_rad"]) for r in records]


class ResultsFolderError(ValueError):
    """The output folder holds results that must not be mixed with or overwritten by this mission."""


class FolderInUseError(ResultsFolderError):
    """Another mission is writing to the output folder."""


class Mission:
    """One active reconstruction mission. Everything it needs is built here: the simulator, the planner,
    the maps it plans on and evaluates (``planning_map``, ``map``; one object when they are the same),
    the evaluator; a stored mission is restored. ``step()`` runs one step; ``run()`` the remaining ones."""

    def __init__(self, config: MissionConfig, out: str | Path | None = None, preset: Preset | None = None,
                 resume: bool = False, overwrite: bool = False, device: str = "cpu"):
        self.config = config
        self.device = check_device(device)  # where the field and the voxel map live (not part of the config)
        self.preset = config.apply(preset or get_preset(config.preset))
        self.scene = load_scene(config.scene)
        self.targets = self.scene.check_targets(config.targets if config.targets else self.scene.targets)
        self.out = Path(out) if out is not None else None
        self.planner = make_planner(config.planner, self.preset, seed=config.seed + 1, replay=config.replay)
        self.records: list[dict] = []
        self.saved_steps = 0  # the steps on disk (a resume continues after them)
        self._lock = None
        self._lock_folder()
        try:
            self._prepare_folder(resume, overwrite)
            self.simulator = Simulator(self.scene)
            self.segmenter = NoisySegmenter(config.label_noise, seed=config.seed)
            kinds = {config.mapper} | ({self.planner.reads} if self.planner.reads else set())
            self.maps: dict[str, ReconstructionMap] = {
                kind: MAP_CLASSES[kind].from_preset(self.preset, seed=config.seed, device=self.device) for kind in sorted(kinds)}
            self.map = self.maps[config.mapper]  # the map that is evaluated
            self.planning_map = self.maps.get(self.planner.reads)  # the map the planner reads (None: map-free)
            self.evaluator = Evaluator(self.simulator, self.targets, self.preset, seed=config.seed)
            self.visited: list[np.ndarray] = []
            if self.records:
                self._restore()
        except BaseException:
            self.release()
            raise

    @property
    def finished(self) -> bool:
        return len(self.records) >= self.config.budget

    # ----------------------------------------------------------------- results folder
    def _header(self) -> dict:
        config = asdict(self.config)
        if config["label_noise"] == EXACT:  # written as before noisy labels existed: those missions stay resumable
            del config["label_noise"]
        return {"config": {**config, "targets": [CLASS_NAMES[t] for t in self.targets]},
                "preset": asdict(self.preset), "scene_file_sha256": scene_file_hash(self.config.scene)}
    def _lock_folder(self) -> None:
        """Hold the results folder's lock file until the mission finishes (``release``): a second process, or a
        second unfinished Mission of this one, is refused instead of racing this one's files."""
        if self.out is None:
            return
        make_output_folder(self.out)
        handle = open(self.out / LOCK_FILE, "a+")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            handle.close()
            raise FolderInUseError(f"{self.out} is in use by another mission (process {holder}): wait for it to end, "
                                   "or choose another folder") from None
        handle.truncate(0)
        handle.write(str(os.getpid()))
        handle.flush()
        self._lock = handle

    def release(self) -> None:
        """Let another mission write to the results folder (done when the mission finishes or its ``run`` ends)."""
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def _prepare_folder(self, resume: bool, overwrite: bool) -> None:
        """Check the folder against this mission. The old results stay until this mission saves its first step,
        also with ``overwrite`` (a mission that fails before that loses nothing)."""
        if self.out is None:
            return
        metrics = self.out / METRICS_FILE
        if metrics.exists() and not overwrite:
            try:
                stored = json.loads(metrics.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as err:
                raise ResultsFolderError(f"{metrics} is unreadable ({err}); use --overwrite to start again") from None
            steps = stored.get("steps", []) if isinstance(stored, dict) else None
            if not isinstance(steps, list) or not all(isinstance(r, dict) and "view_rad" in r for r in steps):
                raise ResultsFolderError(f"{metrics} is unreadable (not a mission's records); use --overwrite to start "
                                         "again")
            mine = json.loads(json.dumps(self._header()))
            if resume:  # a mission may be resumed with a larger budget
                mine["config"]["budget"] = stored.get("config", {}).get("budget")
                mine["preset"]["budget"] = stored.get("preset", {}).get("budget")
            differences = _differences({k: stored.get(k) for k in ("config", "preset")}, {k: mine[k] for k in ("config", "preset")})
            if differences:
                shown = "; ".join(differences[:4]) + (f"; and {len(differences) - 4} more" if len(differences) > 4 else "")
                raise ResultsFolderError(f"{self.out} holds results of a different mission ({shown}); choose another "
                                         "folder or pass --overwrite")
            if stored.get("scene_file_sha256") != mine["scene_file_sha256"]:
                raise ResultsFolderError(
                    f"the scene file {self.config.scene} has changed since {self.out} was started (content "
                    f"{stored.get('scene_file_sha256')}, now {mine['scene_file_sha256']}); restore it, or choose another "
                    "folder or pass --overwrite")
            if resume and self.config.planner == "fixed" and stored["config"]["budget"] != self.config.budget:
                raise ResultsFolderError(
                    f"{self.out} holds a fixed-pattern mission of budget {stored['config']['budget']}; its spiral of views "
                    f"depends on the budget, so it cannot be resumed with budget {self.config.budget}")
            if not resume:
                raise ResultsFolderError(
                    f"{self.out} already holds {len(stored.get('steps', []))} steps of this mission; "
                    "pass --resume to continue it or --overwrite to start again")
            self.records = stored.get("steps", [])[: self.config.budget]
            if len(self.records) < len(stored.get("steps", [])):
                raise ResultsFolderError(f"{self.out} holds {len(stored['steps'])} steps, more than the budget "
                                         f"{self.config.budget}; pass a budget of at least that")
            self.saved_steps = len(self.records)

    def _save(self) -> None:
        if self.out is None:
            return
        state = {"maps": {kind: m.state_dict() for kind, m in self.maps.items()},
                 "planner": self.planner.state_dict(), "steps": len(self.records), "records": self.records}
        tmp = self.out / (CHECKPOINT_FILE + ".tmp")
        try:
            torch.save(state, tmp)
        except (OSError, RuntimeError) as err:  # a full disk surfaces as torch's RuntimeError
            tmp.unlink(missing_ok=True)
            free = shutil.disk_usage(self.out).free
            raise OSError(f"could not write {tmp} ({free / 2**20:.1f} MiB free on its disk: {err}); the "
                          f"{self.saved_steps} steps saved before are kept, continue with --resume") from None
        os.replace(tmp, self.out / CHECKPOINT_FILE)  # from here the step is saved: the checkpoint holds the records too
        self.saved_steps = len(self.records)
        write_json_atomically(self.out / METRICS_FILE, {**self._header(), "steps": self.records})
        # (the budget in the header is the current one: a resumed mission may have raised it)

    def _restore(self) -> None:
        if not (self.out / CHECKPOINT_FILE).exists():
            raise ResultsFolderError(f"{self.out} has {len(self.records)} steps but no {CHECKPOINT_FILE} to resume "
                                     "from; pass --overwrite to start again")
        try:
            state = torch.load(self.out / CHECKPOINT_FILE, weights_only=False, map_location=self.device)
        except Exception as err:  # truncated or not a checkpoint at all: torch and pickle raise many kinds
            raise ResultsFolderError(f"{self.out / CHECKPOINT_FILE} is unreadable ({type(err).__name__}: {err}); "
                                     "pass --overwrite to start the mission again") from None
        if not isinstance(state, dict) or not {"steps", "maps", "planner"} <= set(state):
            raise ResultsFolderError(f"{self.out / CHECKPOINT_FILE} is not a mission checkpoint; pass --overwrite to "
                                     "start the mission again")
        if (state["steps"] == len(self.records) + 1 and "records" in state
                and _steps_and_views(state["records"][:-1]) == _steps_and_views(self.records)):
            # interrupted between the checkpoint and the records: the checkpoint has the newer step, and its records
            self.records = state["records"]
            write_json_atomically(self.out / METRICS_FILE, {**self._header(), "steps": self.records})
            self.saved_steps = len(self.records)
        if state["steps"] != len(self.records):
            raise ResultsFolderError(f"checkpoint in {self.out} is for step {state['steps']}, metrics for step "
                                     f"{len(self.records)}; pass --overwrite to start again")
        for record in self.records:  # the simulator and segmenter are deterministic: measure the same views again
            measurement = self.segmenter(self.simulator.render(view_to_pose(*record["view_rad"])), record["step"])
            for m in self.maps.values():
                m.add_measurement(measurement)
            self.visited.append(np.array(record["view_rad"]))
        for kind, m in self.maps.items():
            m.load_state_dict(state["maps"][kind])
        self.planner.load_state_dict(state["planner"])

    # ----------------------------------------------------------------- the loop
    def step(self) -> dict:
        """One step: plan (the top view first), move and measure, update the maps, evaluate, record and
        save. Returns the step's record."""
        if self.finished:
            raise RuntimeError(f"the mission has made all {self.config.budget} measurements of its budget")
        number = len(self.records) + 1
        start = time.perf_counter()
        if number == 1:
            view, decision = np.array(TOP_VIEW), None
        else:
            source = self.planning_map.planning_source if self.planning_map is not None else None
            decision = self.planner.next_view(source, np.array(self.visited), self.targets)
            view = decision.view
        t_plan = time.perf_counter() - start
        release_freed_memory()  # between phases (allocator.py): the peak is the largest phase's, not their sum
        start = time.perf_counter()
        pose = view_to_pose(*view)
        measurement = self.segmenter(self.simulator.render(pose), number)
        t_measure = time.perf_counter() - start
        start = time.perf_counter()
        history = [loss for m in self.maps.values() for loss in m.integrate(measurement)]
        t_train = time.perf_counter() - start
        release_freed_memory()
        result = self.evaluator.evaluate(self.map)
        release_freed_memory()
        self.visited.append(np.asarray(view, dtype=float))
        record = {
            "step": number,
            "view_deg": np.degrees(view).tolist(),
            "view_rad": np.asarray(view, dtype=float).tolist(),
            "pose": pose.tolist(),
            **dict.fromkeys(SCORE_COLUMNS),
            "loss": history[-1].total if history else None,
            "loss_mean_last10": float(np.mean([h.total for h in history[-10:]])) if history else None,
            **{k: result[k] for k in ("psnr", "psnr_clean", "precision", "completeness", "f1", "chamfer",
                                      *map(f1_column, self.preset.eval.more_f1_thresholds), "phantom")},
            "time_s": {"plan": t_plan, "measure": t_measure, "train": t_train, "evaluate": result["time_total_s"]},
        }
        if decision is not None and decision.scores is not None:
            record.update(decision.scores.columns(decision.chosen_index))
        self.records.append(record)
        self._save()
        if self.finished:
            self.release()
        return record

    def run(self, on_step=None) -> list[dict]:
        """Run the remaining steps; ``on_step(record)`` is called after each (e.g. to print a table row)."""
        try:
            while not self.finished:
                record = self.step()
                if on_step is not None:
                    on_step(record)
        finally:
            self.release()
        return self.records
