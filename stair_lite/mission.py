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

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from .allocator import release_freed_memory
from .classes import CLASS_NAMES
from .config import SEED_LIMIT, Preset, check_device, get_preset
from .evaluation import Evaluator
from .geometry import TOP_VIEW, view_to_pose
from .machine import cpu_model
from .maps import IMPLICIT, MAP_KINDS, ReconstructionMap
from .metrics import METRICS
from .planners import make_planner, planner_class, planner_file_hash
from .results_folder import FORMAT, METRICS_FILE, ResultsFolder, source_hash
from .scenes import load_scene, scene_file_hash
from .segmenter import EXACT, NoisySegmenter, label_noise
from .simulator import Simulator


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
        if cls.reads is not None and cls.reads not in MAP_KINDS:
            raise ValueError(f"planner {self.planner!r} reads a map of kind {cls.reads!r}; the kinds are "
                             f"{', '.join(MAP_KINDS)}")
        label_noise(self.label_noise)  # checks the level's name
        if not 0 <= self.seed < SEED_LIMIT:
            raise ValueError(f"seed must be a whole number from 0 to {SEED_LIMIT - 1}, got {self.seed!r}")
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


@dataclass
class World:
    """What a mission measures and is scored against: the scene, its targets, the simulator, the segmenter (exact or
    noisy labels) and the evaluator. Missions, ``fit``, the headroom instrument and the benchmarks build it here."""

    scene: object
    targets: tuple[int, ...]
    simulator: Simulator
    segmenter: NoisySegmenter
    evaluator: Evaluator

    @classmethod
    def build(cls, scene, preset: Preset, seed: int = 0, targets: tuple[str, ...] | None = None,
              label_noise: str = EXACT) -> "World":
        """The world of a scene (a shipped name, a scene file or a loaded ``Scene``) with ``targets`` (class names;
        None: the scene's)."""
        loaded = load_scene(scene) if isinstance(scene, (str, Path)) else scene
        target_ids = loaded.check_targets(targets if targets else loaded.targets)
        simulator = Simulator(loaded)
        return cls(loaded, target_ids, simulator, NoisySegmenter(label_noise, seed=seed),
                   Evaluator(simulator, target_ids, preset, seed=seed))

    def measure(self, view, step: int):
        """The measurement at ``view`` (elevation, azimuth), as the segmenter labels it at mission step ``step``."""
        return self.segmenter(self.simulator.render(view_to_pose(*view)), step)


def build_map(kind: str, preset: Preset, seed: int = 0, device="cpu") -> ReconstructionMap:
    """An empty map of a registered kind (maps.py)."""
    return MAP_KINDS[kind].from_preset(preset, seed=seed, device=device)


class Mission:
    """One active reconstruction mission. Everything it needs is built here: the simulator, the planner,
    the maps it plans on and evaluates (``planning_map``, ``map``; one object when they are the same),
    the evaluator; a stored mission is restored from its ``ResultsFolder``. ``step()`` runs one step; ``run()``
    the remaining ones.

    ``preset``: the named preset of ``config.preset`` with changes (e.g. a test's smaller grid); its name must be the
    config's, and the config's budget and epsilon apply to it."""

    def __init__(self, config: MissionConfig, out: str | Path | None = None, preset: Preset | None = None,
                 resume: bool = False, overwrite: bool = False, device: str = "cpu"):
        if preset is not None and preset.name != config.preset:
            raise ValueError(f"the preset given is {preset.name!r}, the mission's config names {config.preset!r}")
        self.config = config
        self.device = check_device(device)  # where the field and the voxel map live (not part of the config)
        self.preset = config.apply(preset or get_preset(config.preset))
        self.scene = load_scene(config.scene)
        self.targets = self.scene.check_targets(config.targets if config.targets else self.scene.targets)
        self.planner = make_planner(config.planner, self.preset, seed=config.seed + 1, replay=config.replay)
        self.folder = ResultsFolder(out) if out is not None else None
        self.out = Path(out) if out is not None else None
        self.sources = source_hash()  # recorded with every step: a resumed mission may run on changed code
        self.cpu = cpu_model()  # and the machine: a resume may run on another CPU, whose float sums differ
        self.records: list[dict] = []
        self.saved_steps = 0  # the steps on disk (a resume continues after them)
        if self.folder is not None:
            self.folder.lock()  # before any work: a folder that cannot be written costs nothing
        try:
            if self.folder is not None:
                self.records = self.folder.stored_records(self._header(), config.budget, resume, overwrite,
                                                          budget_fixed=self.planner.depends_on_budget)
                self.saved_steps = len(self.records)
            self.world = World.build(self.scene, self.preset, config.seed, config.targets, config.label_noise)
            self.simulator, self.segmenter, self.evaluator = self.world.simulator, self.world.segmenter, self.world.evaluator
            kinds = {config.mapper} | ({self.planner.reads} if self.planner.reads else set())
            self.maps: dict[str, ReconstructionMap] = {
                kind: build_map(kind, self.preset, config.seed, self.device) for kind in sorted(kinds)}
            self.map = self.maps[config.mapper]  # the map that is evaluated
            self.planning_map = self.maps.get(self.planner.reads)  # the map the planner reads (None: map-free)
            self.visited: list[np.ndarray] = []
            if self.records:
                self._restore()
        except BaseException:
            self.release()
            raise

    @property
    def metrics_path(self) -> Path | None:
        """The mission's records on disk (None for a mission without a results folder)."""
        return self.out / METRICS_FILE if self.out is not None else None

    @property
    def finished(self) -> bool:
        return len(self.records) >= self.config.budget

    def _header(self) -> dict:
        return {"format": FORMAT, "config": {**asdict(self.config), "targets": [CLASS_NAMES[t] for t in self.targets]},
                "preset": asdict(self.preset), "scene_file_sha256": scene_file_hash(self.config.scene),
                "planner_file_sha256": planner_file_hash(self.config.planner)}

    def release(self) -> None:
        """Let another mission write to the results folder (done when the mission finishes or its ``run`` ends)."""
        if self.folder is not None:
            self.folder.release()

    def _save(self) -> None:
        if self.folder is None:
            return
        state = {"maps": {kind: m.state_dict() for kind, m in self.maps.items()}, "planner": self.planner.state_dict()}
        self.folder.save_checkpoint(self._header(), self.records, state, self.saved_steps)
        self.saved_steps = len(self.records)  # from here the step is saved: the checkpoint holds the records too
        self.folder.save_records(self._header(), self.records)
        # (the budget in the header is the current one: a resumed mission may have raised it)

    def _restore(self) -> None:
        state, self.records = self.folder.checkpoint(self._header(), self.records, self.device)
        self.saved_steps = len(self.records)
        for record in self.records:  # the simulator and segmenter are deterministic: measure the same views again
            measurement = self.world.measure(record["view_rad"], record["step"])
            for m in self.maps.values():
                m.add_measurement(measurement)
            self.visited.append(np.array(record["view_rad"]))
        for kind, m in self.maps.items():
            m.load_state_dict(state["maps"][kind])
        self.planner.load_state_dict(state["planner"])

    # ----------------------------------------------------------------- the loop
    def plan(self):
        """The planner's decision on the next view, from what it reads of the maps now (a Decision)."""
        source = self.planning_map.planning_source if self.planning_map is not None else None
        return self.planner.next_view(source, np.array(self.visited), self.targets)

    def step(self) -> dict:
        """One step: plan (the top view first), move and measure, update the maps, evaluate, record and
        save. Returns the step's record: the view, the planner's scores (``score_columns``), the loss, every
        registered metric (metrics.py), the wall time of each phase and the hash of the sources that ran it."""
        if self.finished:
            raise RuntimeError(f"the mission has made all {self.config.budget} measurements of its budget")
        number = len(self.records) + 1
        start = time.perf_counter()
        if number == 1:
            view, decision = np.array(TOP_VIEW), None
        else:
            decision = self.plan()
            view = decision.view
        t_plan = time.perf_counter() - start
        release_freed_memory()  # between phases (allocator.py): the peak is the largest phase's, not their sum
        start = time.perf_counter()
        pose = view_to_pose(*view)
        measurement = self.world.measure(view, number)
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
            **dict.fromkeys(self.planner.score_columns),
            "loss": history[-1].total if history else None,
            "loss_mean_last10": float(np.mean([h.total for h in history[-10:]])) if history else None,
            **{name: metric.value(result, self.map) for name, metric in METRICS.items()},
            "time_s": {"plan": t_plan, "measure": t_measure, "train": t_train, "evaluate": result["time_total_s"]},
            "source_hash": self.sources,
            "cpu": self.cpu,
            "torch_threads": torch.get_num_threads(),
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
