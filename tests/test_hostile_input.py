"""Input a hostile but realistic user gives: files that are not what they claim, studies that must not mix, a
cluster that is not one. Each is refused with one line naming the problem and the value, and nothing is lost."""
import json
import os
import shutil
import socket
import threading
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

import pytest

import stair_lite  # noqa: F401
from stair_lite.__main__ import main
from stair_lite.experiments import collect


def refusal(argv, capsys) -> str:
    """Run the command line; it must refuse with status 2 and one line, no traceback. Returns what it printed."""
    try:
        status = main(argv)
    except SystemExit as stop:
        status = stop.code
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("make", ["device", "link to a device", "fifo", "too large"])
@pytest.mark.parametrize("command", ["run", "scenes", "headroom", "sweep"])
def test_a_scene_file_that_is_no_regular_file_of_sane_size_is_refused_unread(tmp_path, capsys, make, command):
    scene = tmp_path / "scene.json"
    if make == "device":
        scene = "/dev/zero.json"  # not there: named as missing
    elif make == "link to a device":
        scene.symlink_to("/dev/zero")
    elif make == "fifo":
        os.mkfifo(scene)  # reading it would block forever
    else:
        with open(scene, "wb") as f:
            f.truncate(11 * 2**20)  # sparse: 11 MiB of nothing
    argv = {"run": ["run", "--scene", str(scene), "--preset", "smoke", "--out", str(tmp_path / "o")],
            "scenes": ["scenes", str(scene)],
            "headroom": ["headroom", "--scene", str(scene), "--preset", "smoke", "--out", str(tmp_path / "o")],
            "sweep": ["sweep", "--scenes", str(scene), "--planners", "uniform", "--seeds", "1", "--preset", "smoke",
                      "--out", str(tmp_path / "o")]}[command]
    err = refusal(argv, capsys)
    expected = {"device": "scene file not found", "link to a device": "is not a regular file",
                "fifo": "is not a regular file", "too large": "more than a scene needs"}[make]
    assert expected in err and str(scene) in err


def test_a_scene_file_without_its_suffix_gets_a_hint(tmp_path, capsys):
    scene = tmp_path / "mine"
    scene.write_text("{}")
    assert f"{scene} exists, but a scene file's name ends in .json" in refusal(["scenes", str(scene)], capsys)


def smoke_cells(tmp_path, preset="smoke", seeds=(0,), planner="uniform"):
    from stair_lite.experiments import SweepSpec, run_sweep

    run_sweep(SweepSpec(("scene1",), (planner,), seeds, preset, 2), tmp_path, progress=False, log=lambda _: None)


def test_report_and_claims_never_mix_another_studys_cells(tmp_path, capsys):
    """A cell of another preset copied into a smoke folder (its sweep.json says smoke) is reported and left out."""
    smoke_cells(tmp_path / "a", seeds=(0,))
    smoke_cells(tmp_path / "b", seeds=(1,))
    stranger = tmp_path / "a" / "scene1" / "uniform" / "seed1"
    shutil.copytree(tmp_path / "b" / "scene1" / "uniform" / "seed1", stranger)
    header = json.loads((stranger / "metrics.json").read_text())
    header["config"]["preset"] = "lite"
    (stranger / "metrics.json").write_text(json.dumps(header))
    log = []
    rows = collect(tmp_path / "a", log=log.append)
    assert {r["seed"] for r in rows} == {0}
    assert any("another study's mission, preset lite (the folder's: smoke)" in line for line in log)


@pytest.mark.parametrize("content", ['{"config": {"preset": "smoke"}, "steps": [1, 2]}',
                                    '{"config": {"preset": "smoke"}, "steps": [{"step": 1}, {"step": 2}]}', "[1, 2]"])
def test_report_skips_malformed_cells_by_name(tmp_path, capsys, content):
    smoke_cells(tmp_path)
    bad = tmp_path / "scene1" / "uniform" / "seed7" / "metrics.json"
    bad.parent.mkdir()
    bad.write_text(content)
    assert main(["report", "--results", str(tmp_path)]) == 0
    assert f"skipping unreadable {bad}" in capsys.readouterr().err


def test_a_corrupt_sweep_file_and_a_wrong_ablation_folder_are_named(tmp_path, capsys):
    smoke_cells(tmp_path)
    err = refusal(["claims", "--results", str(tmp_path), "--ablation", str(tmp_path)], capsys)
    assert "holds the variants ['uniform']: an epsilon ablation holds only stair_eps<value> variants" in err
    (tmp_path / "sweep.json").write_text("{not json")
    assert f"{tmp_path / 'sweep.json'} is unreadable" in refusal(["report", "--results", str(tmp_path)], capsys)


def test_report_on_a_full_disk_names_the_file_and_leaves_no_cut_file(tmp_path, capsys, monkeypatch):
    import errno

    smoke_cells(tmp_path)
    assert main(["report", "--results", str(tmp_path)]) == 0
    before = (tmp_path / "results.csv").read_text()
    import stair_lite.experiments as experiments

    def full(rows, path):
        open(path, "w").write("scene,var")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(experiments, "write_table", full)
    err = refusal(["report", "--results", str(tmp_path)], capsys)
    assert f"could not write {tmp_path / 'results.csv'}" in err and "MiB free" in err
    assert (tmp_path / "results.csv").read_text() == before and not list(tmp_path.glob("*.tmp"))


def test_two_writers_of_one_file_do_not_take_each_others_temporary_file(tmp_path):
    """Two sweeps' lanes write one summary (results.csv, the curves) at the same moment: each writes its own temporary
    file, so neither renames the other's away (a shared name made the later rename fail: "No such file")."""
    from stair_lite.results_folder import write_json_atomically, written_whole

    target = tmp_path / "results.csv"
    with written_whole(target) as first:
        first.write_text("first")
        with written_whole(target) as second:  # begun and finished while the first is half-written
            assert second != first
            second.write_text("second")
        assert target.read_text() == "second" and first.read_text() == "first"
    assert target.read_text() == "first" and not list(tmp_path.glob("*.tmp"))
    write_json_atomically(tmp_path / "sweep.json", {"preset": "lite"})
    assert json.loads((tmp_path / "sweep.json").read_text()) == {"preset": "lite"} and not list(tmp_path.glob("*.tmp"))


def test_resume_refuses_another_missions_checkpoint(tmp_path, capsys):
    for seed in (0, 1):
        assert main(["run", "--preset", "smoke", "--planner", "uniform", "--budget", "1", "--seed", str(seed),
                     "--quiet", "--out", str(tmp_path / f"s{seed}")]) == 0
    shutil.copy(tmp_path / "s1" / "checkpoint.pt", tmp_path / "s0" / "checkpoint.pt")
    capsys.readouterr()
    err = refusal(["run", "--preset", "smoke", "--planner", "uniform", "--budget", "2", "--seed", "0", "--resume",
                   "--quiet", "--out", str(tmp_path / "s0")], capsys)
    assert "belongs to another mission (config.seed: 1 there, 0 now)" in err


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("server", ["http", "silent"])
def test_a_scheduler_address_that_is_no_dask_scheduler_is_named(tmp_path, capsys, monkeypatch, server):
    import stair_lite.experiments as experiments

    monkeypatch.setattr(experiments, "CONNECT_TIMEOUT_S", 3)
    if server == "http":
        httpd = ThreadingHTTPServer(("127.0.0.1", 0), SimpleHTTPRequestHandler)  # a request that never ends blocks no one
        port = httpd.server_address[1]
        threading.Thread(target=httpd.serve_forever, daemon=True).start()
    else:  # accepts connections and never says a word
        listener = socket.socket()
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        port = listener.getsockname()[1]
    try:
        err = refusal(["sweep", "--scenes", "scene1", "--planners", "uniform", "--seeds", "1", "--preset", "smoke",
                       "--budget", "1", "--quiet", "--scheduler", f"tcp://127.0.0.1:{port}", "--out",
                       str(tmp_path / "o")], capsys)
    finally:
        httpd.shutdown() if server == "http" else listener.close()
    assert f"no Dask scheduler answers at tcp://127.0.0.1:{port} within 3 s" in err


def test_a_cluster_without_workers_is_waited_for_then_given_up(tmp_path, capsys):
    from dask.distributed import LocalCluster

    environ = dict(os.environ)
    cluster = LocalCluster(n_workers=0, processes=True, dashboard_address=None)
    try:
        err = refusal(["sweep", "--scenes", "scene1", "--planners", "uniform", "--seeds", "1", "--preset", "smoke",
                       "--budget", "1", "--quiet", "--scheduler", cluster.scheduler_address, "--worker-timeout", "2",
                       "--out", str(tmp_path / "o")], capsys)
    finally:
        cluster.close()
        os.environ.clear()
        os.environ.update(environ)
    assert "waiting for a worker" in err and "has had no worker for 2 s" in err


def test_a_sweep_with_a_failed_cell_says_so_and_exits_non_zero(tmp_path, capsys):
    planner = tmp_path / "broken.py"
    planner.write_text("from stair_lite.planners import UniformPlanner\n\n\nclass Broken(UniformPlanner):\n"
                       "    def next_view(self, *args, **kwargs):\n        raise RuntimeError('broken on purpose')\n")
    status = main(["sweep", "--scenes", "scene1", "--planners", f"uniform,{planner}:Broken", "--seeds", "1",
                   "--preset", "smoke", "--budget", "2", "--quiet", "--out", str(tmp_path / "o")])
    out, err = capsys.readouterr()
    assert status == 1
    assert "1 cells run" in out and "1 failed or not run: run the same command again to redo them" in out
    assert "broken on purpose" in err


def test_a_scheduler_lost_mid_sweep_is_named_in_one_line(tmp_path, capsys):
    """The scheduler goes away while a cell runs: one line says so (no Dask traceback), the finished cells stay."""
    import time

    from dask.distributed import LocalCluster

    environ = dict(os.environ)
    cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None)
    address = cluster.scheduler_address

    def stop_the_cluster_once_a_step_is_saved():
        deadline = time.time() + 120
        while not list((tmp_path / "o").glob("*/*/seed*/metrics.json")) and time.time() < deadline:
            time.sleep(0.1)
        cluster.close()

    thread = threading.Thread(target=stop_the_cluster_once_a_step_is_saved)
    thread.start()
    try:
        err = refusal(["sweep", "--scenes", "scene1", "--planners", "uniform,fixed", "--seeds", "2", "--preset", "smoke",
                       "--budget", "3", "--quiet", "--scheduler", address, "--out", str(tmp_path / "o")], capsys)
    finally:
        thread.join()
        os.environ.clear()
        os.environ.update(environ)
    assert f"lost the Dask scheduler at {address}" in err and "the finished cells are kept" in err
