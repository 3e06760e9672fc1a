"""A mission's results folder: one writer at a time (a lock file), the records (``metrics.json``) and a checkpoint,
each replaced atomically after every step, and the checks that keep one mission's results from mixing with another's.

Introduced in notebook 05 beside ``mission.py``, which owns the loop; this module owns the files. The stored header
carries a format version (``FORMAT``); ``upgrade_header`` reads every older format, so no other code knows of them.
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import itertools
import json
import os
import shutil
from pathlib import Path

import numpy as np
import torch

METRICS_FILE, CHECKPOINT_FILE, LOCK_FILE = "metrics.json", "checkpoint.pt", ".lock"
# 1: before the version was written (an exact mission's config had no ``label_noise``); 2: every field written
FORMAT = 2
_WRITES = itertools.count()  # numbers this process's temporary files (``written_whole``)


def source_hash() -> str:
    """sha256 of the package's Python sources (the first 16 hex digits): which code produced a result. A sweep's
    ``sweep.json`` records the sources that started it, each step of a mission the sources that ran it."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).resolve().parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def upgrade_header(stored: dict) -> dict:
    """A stored header (or ``sweep.json``) of any format, as the current format writes it."""
    if not isinstance(stored, dict) or stored.get("format", 1) == FORMAT:
        return stored
    upgraded = {**stored, "format": FORMAT}
    if isinstance(stored.get("config"), dict):  # a mission's header: exact labels where none were named
        upgraded["config"] = {"label_noise": "none", **stored["config"]}
    elif "preset" in stored:  # a sweep's header
        upgraded = {"label_noise": "none", **upgraded}
    return upgraded


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
    """Write JSON through ``written_whole``: readers never see a partial file. A score that is not a finite number
    (the PSNR of a perfect image) is written as null: NaN is not JSON."""
    with written_whole(path) as tmp:
        tmp.write_text(json.dumps(_finite_or_null(data), indent=1, allow_nan=False))


@contextlib.contextmanager
def written_whole(path: Path):
    """Write a file through a temporary name beside it, renamed into place once whole: a failure (a full disk) leaves
    the former file, names the file and the free space, and leaves no partial file. The temporary name is this
    writer's own (process and call), so two processes writing one file (a sweep's lanes, each writing the shared
    summary) never rename each other's half-written file: the last whole one wins."""
    path = Path(path)
    tmp = path.with_name(f"{path.name}.{os.getpid()}-{next(_WRITES)}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        free = shutil.disk_usage(path.parent).free
        raise OSError(f"could not write {path} ({free / 2**20:.1f} MiB free on its disk): {err.strerror or err}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _finite_or_null(value):
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(v) for v in value]
    return value


def _differences(stored, mine, where: str = "") -> list[str]:
    """Where two mission headers differ, as "field: stored there X, now Y"."""
    if isinstance(stored, dict) and isinstance(mine, dict):
        return [line for key in sorted(set(stored) | set(mine), key=str)
                for line in _differences(stored.get(key), mine.get(key), f"{where}.{key}" if where else key)]
    return [] if stored == mine else [f"{where}: {stored!r} there, {mine!r} now"]


def _identity(header: dict) -> dict:
    """Which mission a header describes, as a checkpoint records it: its configuration (the budget aside, which a
    resume may raise) and the files it was made from."""
    config = {k: v for k, v in header.get("config", {}).items() if k != "budget"}
    return json.loads(json.dumps({"config": config, **{k: header.get(k) for k in ("scene_file_sha256", "planner_file_sha256")}}))


def _steps_and_views(records: list[dict]) -> list[tuple]:
    return [(r["step"], r["view_rad"]) for r in records]


class ResultsFolderError(ValueError):
    """The output folder holds results that must not be mixed with or overwritten by this mission."""


class FolderInUseError(ResultsFolderError):
    """Another mission is writing to the output folder."""


class ResultsFolder:
    """The folder of one mission's results. ``lock`` holds its lock file until ``release``; ``stored_records`` checks
    what the folder holds against this mission's header; ``save_checkpoint`` and then ``save_records`` write a step;
    ``checkpoint`` reads the state back."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock = None

    def lock(self) -> None:
        """Hold the folder's lock file: a second process, or a second unfinished Mission of this one, is refused
        instead of racing this one's files."""
        make_output_folder(self.path)
        handle = open(self.path / LOCK_FILE, "a+")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            handle.close()
            raise FolderInUseError(f"{self.path} is in use by another mission (process {holder}): wait for it to end, "
                                   "or choose another folder") from None
        handle.truncate(0)
        handle.write(str(os.getpid()))
        handle.flush()
        self._lock = handle

    def release(self) -> None:
        """Let another mission write to the folder."""
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def stored_records(self, header: dict, budget: int, resume: bool, overwrite: bool,
                       budget_fixed: bool = False) -> list[dict]:
        """The records to continue from: none for a new mission (or ``overwrite``: the old results stay until the
        first step is saved, so a mission that fails before that loses nothing), else the stored ones, after checking
        that they are this mission's (``header``); ``budget_fixed``: the planner's views depend on the budget, so a
        resume must keep it."""
        metrics = self.path / METRICS_FILE
        if not metrics.exists() or overwrite:
            return []
        try:
            stored = upgrade_header(json.loads(metrics.read_text()))
        except (json.JSONDecodeError, UnicodeDecodeError) as err:
            raise ResultsFolderError(f"{metrics} is unreadable ({err}); use --overwrite to start again") from None
        steps = stored.get("steps", []) if isinstance(stored, dict) else None
        if not isinstance(steps, list) or not all(isinstance(r, dict) and "view_rad" in r for r in steps):
            raise ResultsFolderError(f"{metrics} is unreadable (not a mission's records); use --overwrite to start again")
        mine = json.loads(json.dumps(header))
        if resume:  # a mission may be resumed with a larger budget
            mine["config"]["budget"] = stored.get("config", {}).get("budget")
            mine["preset"]["budget"] = stored.get("preset", {}).get("budget")
        differences = _differences({k: stored.get(k) for k in ("config", "preset")}, {k: mine[k] for k in ("config", "preset")})
        if differences:
            shown = "; ".join(differences[:4]) + (f"; and {len(differences) - 4} more" if len(differences) > 4 else "")
            raise ResultsFolderError(f"{self.path} holds results of a different mission ({shown}); choose another "
                                     "folder or pass --overwrite")
        for key, what in (("scene_file_sha256", "scene"), ("planner_file_sha256", "planner")):
            if stored.get(key) != mine.get(key):
                raise ResultsFolderError(
                    f"the {what} file {mine['config'][what]} has changed since {self.path} was started (content "
                    f"{stored.get(key)}, now {mine.get(key)}); restore it, or choose another folder or pass --overwrite")
        if resume and budget_fixed and stored["config"]["budget"] != budget:
            raise ResultsFolderError(
                f"{self.path} holds a mission of budget {stored['config']['budget']} whose planner's sequence of views depends on the "
                f"budget, so it cannot be resumed with budget {budget}")
        if not resume:
            raise ResultsFolderError(f"{self.path} already holds {len(steps)} steps of this mission; pass --resume to "
                                     "continue it or --overwrite to start again")
        if len(steps) > budget:
            raise ResultsFolderError(f"{self.path} holds {len(steps)} steps, more than the budget {budget}; pass a budget "
                                     "of at least that")
        return steps

    def save_checkpoint(self, header: dict, records: list[dict], state: dict, saved_before: int) -> None:
        """Write the checkpoint (``state`` with the records and the mission it belongs to) atomically: from its rename
        on, the step is saved. A failure names the steps that are kept (``saved_before``)."""
        tmp = self.path / (CHECKPOINT_FILE + ".tmp")
        try:
            torch.save({**state, "steps": len(records), "records": records, "mission": _identity(header)}, tmp)
        except (OSError, RuntimeError) as err:  # a full disk surfaces as torch's RuntimeError
            tmp.unlink(missing_ok=True)
            free = shutil.disk_usage(self.path).free
            raise OSError(f"could not write {tmp} ({free / 2**20:.1f} MiB free on its disk: {err}); the "
                          f"{saved_before} steps saved before are kept, continue with --resume") from None
        os.replace(tmp, self.path / CHECKPOINT_FILE)

    def save_records(self, header: dict, records: list[dict]) -> None:
        """Write the records after the checkpoint that holds them (an interrupt between the two loses nothing:
        ``checkpoint`` takes the newer step from the checkpoint)."""
        write_json_atomically(self.path / METRICS_FILE, {**header, "steps": records})

    def checkpoint(self, header: dict, records: list[dict], device) -> tuple[dict, list[dict]]:
        """The stored checkpoint for ``records`` and the records to continue from: the checkpoint's own where it is one
        step newer (interrupted between the checkpoint and the records; they are written back)."""
        path = self.path / CHECKPOINT_FILE
        if not path.exists():
            raise ResultsFolderError(f"{self.path} has {len(records)} steps but no {CHECKPOINT_FILE} to resume "
                                     "from; pass --overwrite to start again")
        try:
            state = torch.load(path, weights_only=False, map_location=device)
        except Exception as err:  # truncated or not a checkpoint at all: torch and pickle raise many kinds
            raise ResultsFolderError(f"{path} is unreadable ({type(err).__name__}: {err}); "
                                     "pass --overwrite to start the mission again") from None
        if not isinstance(state, dict) or not {"steps", "maps", "planner"} <= set(state):
            raise ResultsFolderError(f"{path} is not a mission checkpoint; pass --overwrite to start the mission again")
        differences = _differences(state.get("mission"), _identity(header)) if "mission" in state else []
        if differences:
            raise ResultsFolderError(f"{path} belongs to another mission ({'; '.join(differences[:4])}); put back this "
                                     "mission's checkpoint, or pass --overwrite to start it again")
        if (state["steps"] == len(records) + 1 and "records" in state
                and _steps_and_views(state["records"][:-1]) == _steps_and_views(records)):
            records = state["records"]
            write_json_atomically(self.path / METRICS_FILE, {**header, "steps": records})
        if state["steps"] != len(records):
            raise ResultsFolderError(f"checkpoint in {self.path} is for step {state['steps']}, metrics for step "
                                     f"{len(records)}; pass --overwrite to start again")
        return state, records
