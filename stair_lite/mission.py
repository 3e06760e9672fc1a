"""The active reconstruction mission (paper Sec. IV): measure at the top view, then repeat
{train, evaluate, plan, move, measure} until the budget of measurements is spent.

Introduced in notebook 05. After every measurement the mission records the view, the planner's
scores, the training loss, target-only PSNR and target-mesh precision / completeness / F1 and the
wall time of each phase, and writes them to ``metrics.json`` (atomically replaced) together with a
checkpoint, so an interrupted mission loses nothing finished and can be resumed exactly.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from .classes import CLASS_NAMES
from .config import Preset, check_device, get_preset
from .evaluation import Evaluator
from .field import SemanticField
from .geometry import TOP_VIEW, view_to_pose
from .explicit import ExplicitMap
from .planners import PLANNERS, ReplayPlanner, make_planner
from .scenes import load_scene
from .simulator import Simulator
from .training import Trainer

METRICS_FILE, CHECKPOINT_FILE = "metrics.json", "checkpoint.pt"


@dataclass(frozen=True)
class MissionConfig:
    """What defines a mission; two runs with equal configs give the same trajectory and metrics."""

    scene: str = "scene1"
    planner: str = "stair"
    seed: int = 0
    preset: str = "lite"
    targets: tuple[str, ...] | None = None  # None: the scene's own targets
    budget: int = 10
    epsilon: float = 0.2
    mapper: str = "implicit"  # the map that is evaluated: "implicit" (the field) or "explicit" (STE's voxel map)
    replay: str | None = None  # with planner "replay": a metrics.json whose views are followed

    def __post_init__(self):
        if self.planner not in PLANNERS + ("replay",):
            raise ValueError(f"unknown planner {self.planner!r}; choose one of {', '.join(PLANNERS + ('replay',))}")
        if (self.planner == "replay") != (self.replay is not None):
            raise ValueError("planner 'replay' needs a replay file, and a replay file needs planner 'replay'")
        if self.mapper not in ("implicit", "explicit"):
            raise ValueError(f"unknown mapper {self.mapper!r}; choose 'implicit' or 'explicit'")
        if int(self.budget) != self.budget or self.budget < 1:
            raise ValueError(f"budget must be at least 1 measurement, got {self.budget!r}")
        if not self.epsilon >= 0:
            raise ValueError(f"epsilon must be >= 0, got {self.epsilon!r}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed!r}")
        get_preset(self.preset)


def write_json_atomically(path: Path, data) -> None:
    """Write JSON to a temporary file, then rename it over ``path``: readers never see a partial file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


class ResultsFolderError(ValueError):
    """The output folder holds results that must not be mixed with or overwritten by this mission."""


class Mission:
    """One active reconstruction mission. ``run()`` executes (or resumes) it and returns the step records."""

    def __init__(self, config: MissionConfig, out: str | Path | None = None, preset: Preset | None = None,
                 resume: bool = False, overwrite: bool = False, device: str = "cpu"):
        self.config = config
        self.device = check_device(device)  # where the field and the voxel map live (not part of the config)
        self.preset = preset or get_preset(config.preset)
        self.scene = load_scene(config.scene)
        self.targets = self.scene.check_targets(config.targets if config.targets else self.scene.targets)
        self.out = Path(out) if out is not None else None
        self.records: list[dict] = []
        self._prepare_folder(resume, overwrite)

    # ----------------------------------------------------------------- results folder
    def _header(self) -> dict:
        return {"config": {**asdict(self.config), "targets": [CLASS_NAMES[t] for t in self.targets]},
                "preset": asdict(self.preset)}

    def _prepare_folder(self, resume: bool, overwrite: bool) -> None:
        if self.out is None:
            return
        metrics = self.out / METRICS_FILE
        if metrics.exists() and not overwrite:
            try:
                stored = json.loads(metrics.read_text())
            except json.JSONDecodeError as err:
                raise ResultsFolderError(f"{metrics} is unreadable ({err}); use --overwrite to start again") from None
            mine = json.loads(json.dumps(self._header()))
            if resume:  # a mission may be resumed with a larger budget
                mine["config"]["budget"] = stored.get("config", {}).get("budget")
            if {k: stored.get(k) for k in ("config", "preset")} != mine:
                raise ResultsFolderError(
                    f"{self.out} holds results of a different mission ({stored.get('config')}); "
                    "choose another folder or pass --overwrite")
            if not resume:
                raise ResultsFolderError(
                    f"{self.out} already holds {len(stored.get('steps', []))} steps of this mission; "
                    "pass --resume to continue it or --overwrite to start again")
            self.records = stored.get("steps", [])[: self.config.budget]
            if len(self.records) < len(stored.get("steps", [])):
                raise ResultsFolderError(f"{self.out} holds {len(stored['steps'])} steps, more than the budget "
                                         f"{self.config.budget}; pass a budget of at least that")
        elif overwrite:
            for name in (METRICS_FILE, CHECKPOINT_FILE):
                (self.out / name).unlink(missing_ok=True)
        self.out.mkdir(parents=True, exist_ok=True)

    def _save(self, trainer: Trainer, planner, visited: list) -> None:
        if self.out is None:
            return
        state = {
            "field": trainer.field.state_dict(),
            "optimizer": trainer.optimizer.state_dict(),
            "trainer_rng": trainer.rng.bit_generator.state,
            "trainer_generator": trainer.generator.get_state(),
            "use_counts": trainer.buffer.use_counts,
            "planner_rng": planner.rng.bit_generator.state,
            "steps": len(self.records),
        }
        tmp = self.out / (CHECKPOINT_FILE + ".tmp")
        torch.save(state, tmp)
        os.replace(tmp, self.out / CHECKPOINT_FILE)
        write_json_atomically(self.out / METRICS_FILE, {**self._header(), "steps": self.records})
        # (the budget in the header is the current one: a resumed mission may have raised it)

    def _restore(self, trainer: Trainer, explicit: ExplicitMap | None, planner, sim: Simulator) -> list:
        if not (self.out / CHECKPOINT_FILE).exists():
            raise ResultsFolderError(f"{self.out} has {len(self.records)} steps but no {CHECKPOINT_FILE} to resume "
                                     "from; pass --overwrite to start again")
        state = torch.load(self.out / CHECKPOINT_FILE, weights_only=False, map_location=self.device)
        if state["steps"] != len(self.records):
            raise ResultsFolderError(f"checkpoint in {self.out} is for step {state['steps']}, metrics for step "
                                     f"{len(self.records)}; pass --overwrite to start again")
        for record in self.records:  # the simulator is deterministic: measure the same views again
            measurement = sim.render(view_to_pose(*record["view_rad"]))
            trainer.add_measurement(measurement)
            if explicit is not None:  # integration is deterministic too: rebuild the voxel map
                explicit.integrate(measurement)
        trainer.field.load_state_dict(state["field"])
        trainer.optimizer.load_state_dict(state["optimizer"])
        trainer.rng.bit_generator.state = state["trainer_rng"]
        trainer.generator.set_state(state["trainer_generator"])
        trainer.buffer.use_counts = state["use_counts"]
        planner.rng.bit_generator.state = state["planner_rng"]
        return [np.array(r["view_rad"]) for r in self.records]

    # ----------------------------------------------------------------- the loop
    def _make_planner(self):
        cfg, preset = self.config, self.preset
        if cfg.planner == "replay":
            stored = json.loads(Path(cfg.replay).read_text())
            views = np.array([r["view_rad"] for r in stored["steps"]])
            if len(views) < cfg.budget:
                raise ValueError(f"{cfg.replay} holds {len(views)} views, fewer than the budget {cfg.budget}")
            return ReplayPlanner(preset.plan, np.random.default_rng(cfg.seed + 1), views)
        return make_planner(cfg.planner, preset.plan, seed=cfg.seed + 1, epsilon=cfg.epsilon, budget=cfg.budget,
                            n_ste_candidates=preset.explicit.n_candidates)

    def run(self, on_step=None) -> list[dict]:
        """Run the remaining steps; ``on_step(record)`` is called after each (e.g. to print a table row)."""
        cfg, preset = self.config, self.preset
        sim = Simulator(self.scene)
        field = SemanticField(preset.field, seed=cfg.seed).to(self.device)
        trainer = Trainer(field, preset.train, preset.render, seed=cfg.seed)
        explicit = ExplicitMap(preset.explicit, device=self.device) if cfg.mapper == "explicit" or cfg.planner == "ste" else None
        train_field = cfg.mapper == "implicit" or cfg.planner in ("stair", "exploration")
        planner = self._make_planner()
        evaluator = Evaluator(sim, self.targets, preset, seed=cfg.seed)
        visited = self._restore(trainer, explicit, planner, sim) if self.records else []
        self.field, self.explicit, self.evaluator = field, explicit, evaluator
        for step in range(len(self.records) + 1, cfg.budget + 1):
            start = time.perf_counter()
            if step == 1:
                view, decision = np.array(TOP_VIEW), None
            else:
                decision = planner.next_view(explicit if cfg.planner == "ste" else field, np.array(visited), self.targets)
                view = decision.view
            t_plan = time.perf_counter() - start
            start = time.perf_counter()
            pose = view_to_pose(*view)
            measurement = sim.render(pose)
            t_measure = time.perf_counter() - start
            start = time.perf_counter()
            trainer.add_measurement(measurement)
            history = trainer.update() if train_field else []
            if explicit is not None:
                explicit.integrate(measurement)
            t_train = time.perf_counter() - start
            result = evaluator.evaluate(explicit if cfg.mapper == "explicit" else field)
            visited.append(np.asarray(view, dtype=float))
            record = {
                "step": step,
                "view_deg": np.degrees(view).tolist(),
                "view_rad": np.asarray(view, dtype=float).tolist(),
                "pose": pose.tolist(),
                "utility": None, "exploitation": None, "exploration": None,
                "loss": history[-1].total if history else None,
                "loss_mean_last10": float(np.mean([h.total for h in history[-10:]])) if history else None,
                **{k: result[k] for k in ("psnr", "psnr_clean", "precision", "completeness", "f1", "chamfer")},
                "time_s": {"plan": t_plan, "measure": t_measure, "train": t_train, "evaluate": result["time_total_s"]},
            }
            if decision is not None and decision.scores is not None:
                i = decision.chosen_index
                record.update(utility=float(decision.scores.utility[i]), exploitation=float(decision.scores.exploitation[i]),
                              exploration=float(decision.scores.exploration[i]))
            self.records.append(record)
            self.last_mesh = result["mesh"]
            self._save(trainer, planner, visited)
            if on_step is not None:
                on_step(record)
        return self.records
