import json
import os
from pathlib import Path

import pytest

import stair_lite  # noqa: F401
from stair_lite.experiments import Cell, SweepSpec, cell_state, collect, read_table, run_cell, run_sweep, summary, write_table


def spec(**kw):
    base = dict(scenes=("scene1",), variants=("uniform", "ste", "ste_implicit"), seeds=(0,), preset="smoke", budget=2)
    return SweepSpec(**{**base, **kw})


def test_sweep_runs_resumes_and_tabulates(tmp_path):
    outcomes = run_sweep(spec(), tmp_path, progress=False)
    assert sorted(o for _, o in outcomes) == ["ran"] * 3
    again = run_sweep(spec(), tmp_path, progress=False)
    assert all(o == "finished before" for _, o in again)  # a finished cell is never recomputed
    rows = collect(tmp_path)
    assert len(rows) == 3 * 2 and {r["variant"] for r in rows} == {"uniform", "ste", "ste_implicit"}
    ste = [r for r in rows if r["variant"] == "ste"]
    replay = [r for r in rows if r["variant"] == "ste_implicit"]
    assert [r["azimuth_deg"] for r in ste] == [r["azimuth_deg"] for r in replay]
    table = read_table(write_table(rows, tmp_path / "results.csv"))
    assert len(table) == 6 and table[0]["psnr"] == pytest.approx(rows[0]["psnr"])
    entry = next(e for e in summary(table) if e["variant"] == "uniform")
    uniform = sorted((r for r in table if r["variant"] == "uniform"), key=lambda r: r["step"])
    assert entry["psnr_final_mean"] == pytest.approx(uniform[-1]["psnr"])
    assert entry["psnr_auc_mean"] == pytest.approx((uniform[0]["psnr"] + uniform[1]["psnr"]) / 2)


def test_report_shows_every_metric_with_areas_under_the_curves(tmp_path, capsys):
    from stair_lite.__main__ import main

    run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
    assert main(["report", "--results", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    header = next(line for line in out.splitlines() if line.startswith("scene "))
    for metric in ("psnr", "psnr_clean", "f1", "f1_2cm", "f1_5cm", "chamfer"):
        assert metric in header.split() and (tmp_path / f"curves_{metric}.png").exists()
    row = next(line for line in out.splitlines() if line.startswith("scene1"))
    rows = collect(tmp_path)
    chamfer_auc_cm = 100 * sum(r["chamfer"] for r in rows) / len(rows)
    assert f"{chamfer_auc_cm:7.3f}" in row  # the chamfer's area under the curve, in cm


def test_corrupt_cell_is_reported_and_redone(tmp_path):
    run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
    path = Cell("scene1", "uniform", 0).folder(tmp_path) / "metrics.json"
    path.write_text("{ half a file")
    messages = []
    outcomes = run_sweep(spec(variants=("uniform",)), tmp_path, progress=False, log=messages.append)
    assert any("corrupt" in m for m in messages)
    assert outcomes[0][1].startswith("redone")
    assert len(json.loads(path.read_text())["steps"]) == 2
    path.write_text("{ again")
    assert collect(tmp_path, log=messages.append) == []  # collecting skips it without crashing
    assert any("skipping unreadable" in m for m in messages)


def test_results_folder_of_another_configuration_is_refused(tmp_path):
    run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
    with pytest.raises(ValueError, match="another folder"):
        run_sweep(spec(variants=("uniform",), budget=3), tmp_path, progress=False)
    with pytest.raises(ValueError, match="label noise 'none'; use another folder for .* label noise 'high'"):
        run_sweep(spec(variants=("uniform",), label_noise="high"), tmp_path, progress=False)
    sweep_file = tmp_path / "sweep.json"  # a folder written before noisy labels existed holds exact ones
    stored = json.loads(sweep_file.read_text())
    del stored["label_noise"], stored["format"]
    sweep_file.write_text(json.dumps(stored))
    run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
    with pytest.raises(ValueError, match="label noise 'none'"):
        run_sweep(spec(variants=("uniform",), label_noise="low"), tmp_path, progress=False)


def test_a_noisy_sweep_runs_its_cells_with_the_noisy_segmenter(tmp_path):
    run_sweep(spec(variants=("uniform",), seeds=(0,), label_noise="high"), tmp_path, progress=False)
    cell = spec(variants=("uniform",), seeds=(0,)).cells()[0]
    assert json.loads((cell.folder(tmp_path) / "metrics.json").read_text())["config"]["label_noise"] == "high"


@pytest.mark.parametrize("kw,match", [({"scenes": ("scene9",)}, "unknown scene"), ({"variants": ("greedy",)}, "unknown planner variant"),
                                       ({"seeds": (-1,)}, "non-negative"), ({"variants": ("stair_epsx",)}, "unknown planner variant"),
                                       ({"label_noise": "loud"}, "unknown label noise level 'loud'")])
def test_bad_sweep_settings_are_named(kw, match):
    with pytest.raises(ValueError, match=match):
        spec(**kw)


def test_cells_run_seed_by_seed_with_replays_after_their_source():
    cells = spec(variants=("ste_implicit", "uniform", "ste"), seeds=(0, 1)).cells()
    assert [c.seed for c in cells] == [0, 0, 0, 1, 1, 1]
    for k in (0, 1):
        order = [c.variant for c in cells if c.seed == k]
        assert order.index("ste") < order.index("ste_implicit")


def test_parallel_sweep_starts_a_replay_once_its_source_is_done(tmp_path):
    import os

    environ = dict(os.environ)
    outcomes = run_sweep(spec(variants=("ste", "ste_implicit")), tmp_path, workers=2, progress=False)
    assert dict(os.environ) == environ  # the local cluster's workers leave this process's threads alone
    assert [(c.variant, o) for c, o in outcomes] == [("ste", "ran"), ("ste_implicit", "ran")]
    rows = collect(tmp_path)
    assert len(rows) == 4


def test_replay_without_its_source_is_refused(tmp_path):
    with pytest.raises(ValueError, match="replays the views of stair"):
        run_sweep(spec(variants=("stair_explicit",)), tmp_path, progress=False)


def test_collect_leaves_out_unfinished_cells(tmp_path):
    run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
    path = Cell("scene1", "uniform", 0).folder(tmp_path) / "metrics.json"
    stored = json.loads(path.read_text())
    stored["steps"] = stored["steps"][:1]
    path.write_text(json.dumps(stored))
    messages = []
    assert collect(tmp_path, log=messages.append) == []
    assert any("unfinished" in m for m in messages)


def test_a_dead_worker_fails_its_cell_and_the_rerun_completes_the_table(tmp_path):
    """A smoke sweep on a local Dask cluster of 2 workers (reached by its scheduler's address, as a lab's
    cluster would be); one worker is killed while it runs a cell. The sweep goes on, reports that cell
    as failed, and the next run completes the table."""
    import os
    import signal
    import threading
    import time

    import dask
    from dask.distributed import Client, LocalCluster

    sweep = spec(variants=("uniform", "fixed", "max_distance"), seeds=(0, 1), budget=3)
    environ = dict(os.environ)  # starting workers sets OMP_NUM_THREADS=1 here too: restored below
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    watcher = Client(cluster)
    killed = []

    def kill_a_busy_worker():
        deadline = time.time() + 120
        while not killed and time.time() < deadline:
            busy = [w for w, tasks in watcher.processing().items() if tasks]
            started = list(tmp_path.glob("*/*/seed*/metrics.json"))  # some cell has finished a step
            if busy and started:
                pid = watcher.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            time.sleep(0.05)

    thread = threading.Thread(target=kill_a_busy_worker)
    thread.start()
    try:
        outcomes = run_sweep(sweep, tmp_path, progress=False, scheduler=cluster.scheduler_address)
    finally:
        thread.join()
        watcher.close()
        cluster.close()
        os.environ.clear()
        os.environ.update(environ)
    assert killed and len(outcomes) == 6
    failed = [c for c, o in outcomes if o.startswith("failed")]
    assert len(failed) == 1, outcomes
    rerun = run_sweep(sweep, tmp_path, progress=False, workers=2)
    assert sorted(o for _, o in rerun).count("finished before") == 5
    rows = collect(tmp_path)
    assert len(rows) == 6 * 3 and {(r["variant"], r["seed"]) for r in rows} == {(v, k) for v in sweep.variants for k in (0, 1)}


def test_cells_run_in_this_process_at_one_thread(tmp_path, monkeypatch):
    """A stored cell must not depend on how its sweep was started: in-process cells run at one torch thread, as a
    cluster's workers do (float sums depend on the thread count), and the process's count is restored."""
    import torch

    import stair_lite.experiments as experiments

    seen = []

    class Recorder:
        def __init__(self, *args, **kwargs):
            seen.append(torch.get_num_threads())

        def run(self):
            raise RuntimeError("recorded")

    monkeypatch.setattr(experiments, "Mission", Recorder)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        outcomes = run_sweep(spec(variants=("uniform",)), tmp_path, progress=False)
        assert seen == [1] and torch.get_num_threads() == 2
        assert outcomes[0][1].startswith("failed (RuntimeError: recorded)")  # reported as a cluster reports it
    finally:
        torch.set_num_threads(before)


@pytest.mark.parametrize("content", ['{"steps": 5}', '[1, 2]', '{"steps": [1, 2]}'])
def test_a_cell_with_malformed_records_is_corrupt_and_redone(tmp_path, content):
    cell = Cell("scene1", "uniform", 0)
    cell.folder(tmp_path).mkdir(parents=True)
    (cell.folder(tmp_path) / "metrics.json").write_text(content)
    assert cell_state(cell, tmp_path, 2) == "corrupt"
    _, outcome = run_cell(cell, str(tmp_path), "smoke", 2)
    assert outcome == "redone (was corrupt)" and cell_state(cell, tmp_path, 2) == "done"


def test_a_cell_with_a_truncated_checkpoint_is_redone(tmp_path):
    cell = Cell("scene1", "uniform", 0)
    run_cell(cell, str(tmp_path), "smoke", 1)
    checkpoint = cell.folder(tmp_path) / "checkpoint.pt"
    checkpoint.write_bytes(checkpoint.read_bytes()[:100])
    _, outcome = run_cell(cell, str(tmp_path), "smoke", 2)   # resuming it reads the checkpoint
    assert outcome.startswith("redone") and "checkpoint.pt is unreadable" in outcome
    assert cell_state(cell, tmp_path, 2) == "done"


def test_a_sweep_runs_on_a_scene_file_and_refuses_it_once_edited(tmp_path):
    scene = tmp_path / "scenes" / "mine.json"
    scene.parent.mkdir()
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]}]}))
    spec = SweepSpec((str(scene),), ("uniform",), (0,), "smoke", 1)
    run_sweep(spec, tmp_path / "out", progress=False)
    assert [r["scene"] for r in collect(tmp_path / "out")] == ["mine"]
    assert "mine" in json.loads((tmp_path / "out" / "sweep.json").read_text())["scene_files"]
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.3, 0.0]}]}))
    with pytest.raises(ValueError, match=r"results of other scenes named \['mine'\] \(scene content mine: \w+ there, "
                                         r"\w+ now\)"):
        run_sweep(spec, tmp_path / "out", progress=False)
    with pytest.raises(FileNotFoundError, match="scene file not found"):
        SweepSpec((str(tmp_path / "missing.json"),), ("uniform",), (0,), "smoke", 1)


@pytest.mark.parametrize("file_first", [False, True])
def test_a_scene_file_named_like_a_shipped_scene_never_shares_its_cells(tmp_path, file_first):
    """A file scene1.json of other content than the shipped scene1 would be stored under the same folder name:
    whichever comes second is refused, instead of reusing (or redoing) the other's cells."""
    other = tmp_path / "mine" / "scene1.json"
    other.parent.mkdir()
    other.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]}]}))
    shipped, mine = (SweepSpec((name,), ("uniform",), (0,), "smoke", 1) for name in ("scene1", str(other)))
    first, second = (mine, shipped) if file_first else (shipped, mine)
    run_sweep(first, tmp_path / "out", progress=False)
    stored = (Cell("scene1", "uniform", 0).folder(tmp_path / "out") / "metrics.json").read_text()
    with pytest.raises(ValueError, match=r"results of other scenes named \['scene1'\]"):
        run_sweep(second, tmp_path / "out", progress=False)
    assert (Cell("scene1", "uniform", 0).folder(tmp_path / "out") / "metrics.json").read_text() == stored
    run_sweep(first, tmp_path / "out", progress=False)  # the same scene again is welcome


@pytest.mark.parametrize("stop", ["ctrl-c twice", "SIGTERM", "SIGKILL"])
def test_a_stopped_sweep_stops_its_workers(tmp_path, stop):
    """A 2-worker sweep from the command line, stopped once its first step is saved: Ctrl-C (sent to the
    terminal's whole process group, twice), SIGTERM or SIGKILL of the sweep's process. Within a minute no
    worker is left to go on with the queue (so no cell finishes after the stop) and nothing prints a traceback."""
    import signal
    import subprocess
    import sys
    import time

    import psutil

    seeds, budget = 12, 3  # more work than the sweep can finish between its first saved step and the stop
    command = [sys.executable, "-m", "stair_lite", "sweep", "--scenes", "scene1", "--planners", "uniform,fixed",
               "--seeds", str(seeds), "--budget", str(budget), "--preset", "smoke", "--workers", "2", "--quiet", "--out", str(tmp_path)]
    # a terminal's Ctrl-C reaches a sweep whose SIGINT is live: a test session started in the background (where the
    # shell ignores SIGINT, and children inherit that) must not pass its ignored SIGINT on to the sweep
    sweep = subprocess.Popen(command, cwd=Path(__file__).parents[1], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             start_new_session=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.time() + 300
        while not list(tmp_path.glob("*/*/seed*/metrics.json")) and time.time() < deadline:
            time.sleep(0.1)
        workers = psutil.Process(sweep.pid).children(recursive=True)
        assert list(tmp_path.glob("*/*/seed*/metrics.json")) and workers
        if stop == "ctrl-c twice":
            os.killpg(sweep.pid, signal.SIGINT)
            time.sleep(0.3)
            os.killpg(sweep.pid, signal.SIGINT)
        else:
            sweep.send_signal(getattr(signal, stop))
        output = sweep.communicate(timeout=60)[0]
        gone, alive = psutil.wait_procs(workers, timeout=60)
        assert not alive, f"workers still running after the sweep stopped: {alive}"
    finally:
        for process in psutil.Process(sweep.pid).children(recursive=True) if sweep.poll() is None else []:
            process.kill()
        sweep.kill()
    assert "Traceback" not in output, output
    if stop != "SIGKILL":
        assert sweep.returncode == 130 and "interrupted: finished cells are kept" in output, output
    cells = spec(variants=("uniform", "fixed"), seeds=tuple(range(seeds))).cells()
    finished = [c for c in cells if cell_state(c, tmp_path, budget) == "done"]
    assert len(finished) < len(cells), "the sweep ended before it was stopped: the test proves nothing"


def test_a_cross_validation_cell_runs_before_the_next_seeds_cells(tmp_path):
    """A sweep stopped early holds whole seeds of every variant: the cell that replays another runs as soon as that
    one has finished, before the cells of the next seed."""
    outcomes = run_sweep(spec(variants=("ste", "ste_implicit"), seeds=(0, 1), budget=1), tmp_path, progress=False)
    assert [(c.variant, c.seed) for c, _ in outcomes] == [("ste", 0), ("ste_implicit", 0), ("ste", 1), ("ste_implicit", 1)]
