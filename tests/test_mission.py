import json
import os
from dataclasses import replace

import numpy as np
import pytest
import torch

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.machine import cpu_model
from stair_lite.mission import Mission, MissionConfig
from stair_lite.results_folder import FORMAT, FolderInUseError, ResultsFolderError, source_hash

TINY = get_preset("smoke")


def run(tmp_path, name="m", budget=3, planner="stair", on_step=None, preset=TINY, **kw):
    mission = Mission(MissionConfig(preset="smoke", planner=planner, budget=budget), out=tmp_path / name, preset=preset, **kw)
    return mission.run(on_step=on_step)


def strip_times(records):
    return [{k: v for k, v in r.items() if k != "time_s"} for r in records]


def test_same_seed_same_mission(tmp_path):
    a, b = run(tmp_path, "a"), run(tmp_path, "b")
    assert strip_times(a) == strip_times(b)
    assert a[0]["view_deg"] == [90.0, 0.0]  # every mission starts at the top view
    assert a[0]["utility"] is None and a[1]["utility"] is not None
    for r in a:
        assert set(r["time_s"]) == {"plan", "measure", "train", "evaluate"}
        assert 0 <= r["f1"] <= 1 and np.isfinite(r["psnr"])
    stored = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert stored["config"]["planner"] == "stair" and len(stored["steps"]) == 3


@pytest.mark.parametrize("preset", [replace(TINY, field=replace(TINY.field, reached_only=rule)) for rule in (True, False)],
                         ids=["reached_only", "head_everywhere"])  # the reached cells are re-marked from the measurements
def test_interrupted_mission_keeps_its_steps_and_resumes_exactly(tmp_path, preset):
    full = run(tmp_path, "full", budget=3, preset=preset)

    def stop_after_two(record):
        if record["step"] == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(tmp_path, "cut", budget=3, on_step=stop_after_two, preset=preset)
    saved = json.loads((tmp_path / "cut" / "metrics.json").read_text())
    assert [r["step"] for r in saved["steps"]] == [1, 2]
    resumed = run(tmp_path, "cut", budget=3, resume=True, preset=preset)
    assert strip_times(resumed) == strip_times(full)


def test_interrupted_ste_mission_resumes_exactly(tmp_path):
    """The explicit map is rebuilt from the stored views, the planner's generator from the checkpoint."""
    full = run(tmp_path, "full", budget=4, planner="ste")

    def stop_after_two(record):
        if record["step"] == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(tmp_path, "cut", budget=4, planner="ste", on_step=stop_after_two)
    resumed = run(tmp_path, "cut", budget=4, planner="ste", resume=True)
    assert strip_times(resumed) == strip_times(full)
    assert all(r["ste_utility"] is not None and "utility" not in r for r in full[1:])  # a record holds its planner's own scores


def test_a_mission_is_built_whole_and_stepped(tmp_path):
    mission = Mission(MissionConfig(preset="smoke", planner="stair", budget=2), out=tmp_path / "m", preset=TINY)
    assert mission.map is mission.planning_map and set(mission.maps) == {"implicit"}
    assert mission.evaluator.targets == mission.targets and mission.records == []
    first = mission.step()
    assert first["step"] == 1 and mission.records == [first] and not mission.finished
    assert mission.step()["step"] == 2 and mission.finished
    with pytest.raises(RuntimeError, match="all 2 measurements"):
        mission.step()
    ste = Mission(MissionConfig(preset="smoke", planner="ste", budget=1), preset=TINY)
    assert set(ste.maps) == {"explicit"} and ste.config.mapper == "explicit"  # an STE mission builds no field
    replay = Mission(MissionConfig(preset="smoke", planner="replay", replay=str(tmp_path / "m" / "metrics.json"), mapper="explicit",
                                   budget=2), preset=TINY)
    assert set(replay.maps) == {"explicit"} and replay.planning_map is None


def test_the_stored_header_records_what_the_mission_ran_with(tmp_path):
    Mission(MissionConfig(preset="smoke", planner="stair", epsilon=0.5, budget=1), out=tmp_path, preset=TINY).run()
    header = json.loads((tmp_path / "metrics.json").read_text())
    assert header["config"]["epsilon"] == header["preset"]["plan"]["epsilon"] == 0.5
    assert header["config"]["budget"] == header["preset"]["budget"] == 1
    assert header["config"]["mapper"] == "implicit"


def test_each_step_records_the_sources_and_the_machine_that_ran_it(tmp_path, monkeypatch):
    """A resumed mission's steps may run on other code, another CPU or another thread count than its first ones: each
    step names its own."""
    run(tmp_path, "m", budget=1)
    monkeypatch.setattr("stair_lite.mission.source_hash", lambda: "0123456789abcdef")  # as if the code had changed
    monkeypatch.setattr("stair_lite.mission.cpu_model", lambda: "Another CPU (family 1, model 2, stepping 3)")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        run(tmp_path, "m", budget=2, resume=True)
    finally:
        torch.set_num_threads(threads)
    steps = json.loads((tmp_path / "m" / "metrics.json").read_text())["steps"]
    assert [r["source_hash"] for r in steps] == [source_hash(), "0123456789abcdef"]
    assert len(source_hash()) == 16 and int(source_hash(), 16) >= 0
    assert [r["cpu"] for r in steps] == [cpu_model(), "Another CPU (family 1, model 2, stepping 3)"]
    assert [r["torch_threads"] for r in steps] == [threads, 1]


def test_results_folder_is_protected(tmp_path):
    run(tmp_path, "x", budget=1)
    with pytest.raises(ResultsFolderError, match="--resume"):
        run(tmp_path, "x", budget=1)
    with pytest.raises(ResultsFolderError, match=r"different mission \(config.planner: 'stair' there, 'uniform' now\)"):
        run(tmp_path, "x", budget=1, planner="uniform")
    assert len(run(tmp_path, "x", budget=1, planner="uniform", overwrite=True)) == 1
    (tmp_path / "x" / "metrics.json").write_text("{ broken")
    with pytest.raises(ResultsFolderError, match="unreadable"):
        run(tmp_path, "x", budget=1, planner="uniform", resume=True)


@pytest.mark.parametrize("kw,match", [
    ({"budget": 0}, "budget must be a whole number of measurements from 1 to 50"), ({"budget": 51}, "from 1 to 50, got 51"),
    ({"epsilon": -0.5}, "epsilon must be a number from 0 to 1e"), ({"epsilon": float("inf")}, "from 0 to 1e\\+06, got inf"),
    ({"epsilon": 3.5e38}, "from 0 to 1e\\+06, got 3.5e\\+38"),
    ({"planner": "random"}, "unknown planner"), ({"targets": ("boat",)}, "unknown class name"),
    ({"label_noise": "loud"}, "unknown label noise level 'loud'")])
def test_bad_mission_settings_are_named(kw, match):
    with pytest.raises(ValueError, match=match):
        Mission(MissionConfig(preset="smoke", **kw), preset=TINY)


def test_targets_must_be_in_the_scene():
    with pytest.raises(ValueError, match="do not occur in scene"):
        Mission(MissionConfig(preset="smoke", scene="scene2", targets=("car",)), preset=TINY)


def test_a_mission_with_noisy_labels_trains_on_them_resumes_exactly_and_is_scored_on_exact_ones(tmp_path):
    full = Mission(MissionConfig(preset="smoke", planner="stair", budget=3, label_noise="high"), out=tmp_path / "full", preset=TINY)
    records = full.run()
    exact_mission = Mission(MissionConfig(preset="smoke", planner="stair", budget=3), out=tmp_path / "exact", preset=TINY)
    exact = exact_mission.run()
    assert strip_times(records) != strip_times(exact)  # the labels changed what was learnt
    assert all(np.array_equal(a, b) for a, b in zip(full.evaluator.gt_images, exact_mission.evaluator.gt_images))
    stored = json.loads((tmp_path / "full" / "metrics.json").read_text())
    assert stored["config"]["label_noise"] == "high"
    exact_header = json.loads((tmp_path / "exact" / "metrics.json").read_text())
    assert exact_header["config"]["label_noise"] == "none" and exact_header["format"] == FORMAT

    def stop_after_two(record):
        if record["step"] == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        Mission(MissionConfig(preset="smoke", planner="stair", budget=3, label_noise="high"), out=tmp_path / "cut", preset=TINY).run(
            on_step=stop_after_two)
    resumed = Mission(MissionConfig(preset="smoke", planner="stair", budget=3, label_noise="high"), out=tmp_path / "cut", preset=TINY,
                      resume=True).run()
    assert strip_times(resumed) == strip_times(records)
    with pytest.raises(ResultsFolderError, match=r"different mission \(config.label_noise: 'high' there, 'low' now\)"):
        Mission(MissionConfig(preset="smoke", planner="stair", budget=3, label_noise="low"), out=tmp_path / "cut", preset=TINY, resume=True)
    with pytest.raises(ResultsFolderError, match=r"different mission \(config.label_noise: 'high' there, 'none' now\)"):
        Mission(MissionConfig(preset="smoke", planner="stair", budget=3), out=tmp_path / "cut", preset=TINY, resume=True)


@pytest.mark.parametrize("planner", ["stair_soft", "stair_semantic"])
def test_the_planners_beyond_the_paper_complete_a_noisy_mission(tmp_path, planner):
    mission = Mission(MissionConfig(preset="smoke", planner=planner, budget=2, label_noise="medium"), out=tmp_path, preset=TINY)
    records = mission.run()
    assert len(records) == 2 and records[1]["semantic_uncertainty"] >= 0


@pytest.mark.parametrize("planner", ["exploration", "fixed", "max_distance", "uniform"])
def test_every_planner_completes_a_mission(tmp_path, planner):
    records = run(tmp_path, planner, budget=2, planner=planner)
    assert len(records) == 2 and records[1]["view_deg"] != records[0]["view_deg"]


def test_ste_mission_and_the_cross_validation_replay(tmp_path):
    ste = Mission(MissionConfig(preset="smoke", planner="ste", mapper="explicit", budget=3), out=tmp_path / "ste", preset=TINY).run()
    assert ste[1]["ste_utility"] is not None and ste[0]["loss"] is None  # the explicit map is not trained
    implicit = Mission(MissionConfig(preset="smoke", planner="replay", replay=str(tmp_path / "ste" / "metrics.json"), budget=3),
                       out=tmp_path / "ste_implicit", preset=TINY).run()
    assert [r["view_rad"] for r in implicit] == [r["view_rad"] for r in ste]  # STE's views, the field's map
    assert implicit[-1]["loss"] is not None


def test_replay_needs_a_file_and_enough_views(tmp_path):
    with pytest.raises(ValueError, match="needs a replay file"):
        MissionConfig(planner="replay")
    run(tmp_path, "short", budget=2, planner="uniform")
    with pytest.raises(ValueError, match="fewer than the budget"):
        Mission(MissionConfig(preset="smoke", planner="replay", replay=str(tmp_path / "short" / "metrics.json"), budget=3), preset=TINY)


@pytest.mark.parametrize("device,match", [("tpu", "unknown device|only 'cpu' and 'cuda'"), ("not a device", "unknown device")])
def test_bad_devices_are_named(device, match):
    with pytest.raises(ValueError, match=match):
        Mission(MissionConfig(preset="smoke", budget=1), device=device)


@pytest.mark.skipif(__import__("torch").cuda.is_available(), reason="this machine has a GPU")
def test_asking_for_a_missing_gpu_is_a_clear_error():
    with pytest.raises(ValueError, match="sees no CUDA GPU"):
        Mission(MissionConfig(preset="smoke", budget=1), device="cuda")


@pytest.mark.skipif(not __import__("torch").cuda.is_available(), reason="needs a CUDA GPU")
@pytest.mark.parametrize("planner", ["stair", "ste"])
def test_a_mission_runs_on_the_gpu(tmp_path, planner):
    records = Mission(MissionConfig(planner=planner, preset="smoke", budget=2, mapper="explicit" if planner == "ste" else "implicit"),
                      out=tmp_path, device="cuda").run()
    assert len(records) == 2 and np.isfinite(records[-1]["psnr"])


def test_overwrite_keeps_the_old_results_until_the_new_mission_saves(tmp_path, monkeypatch):
    """--overwrite of a folder that holds a mission: a new mission that fails (or is interrupted) before its first
    step is saved leaves the old results as they were."""
    old = run(tmp_path, "x", budget=2)
    replay = tmp_path / "short.json"
    replay.write_text(json.dumps({"steps": old[:1]}))
    with pytest.raises(ValueError, match="fewer than the budget 3"):
        Mission(MissionConfig(preset="smoke", planner="replay", replay=str(replay), budget=3), out=tmp_path / "x", preset=TINY,
                overwrite=True)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("stair_lite.mission.Evaluator", interrupted)  # Ctrl-C while the new mission is being built
    with pytest.raises(KeyboardInterrupt):
        run(tmp_path, "x", budget=1, planner="uniform", overwrite=True)
    assert json.loads((tmp_path / "x" / "metrics.json").read_text())["steps"] == json.loads(json.dumps(old))
    assert (tmp_path / "x" / "checkpoint.pt").exists()
    monkeypatch.undo()
    assert len(run(tmp_path, "x", budget=1, planner="uniform", overwrite=True)) == 1  # saving replaces them


def test_an_interrupt_between_checkpoint_and_records_loses_no_step(tmp_path, monkeypatch):
    full = run(tmp_path, "full", budget=3)
    from stair_lite import results_folder as mission_module

    writes = []
    original = mission_module.write_json_atomically

    def interrupted_on_step_two(path, data):
        writes.append(len(data["steps"]))
        if len(data["steps"]) == 2:
            raise KeyboardInterrupt  # after the checkpoint of step 2 was replaced, before its records
        original(path, data)

    monkeypatch.setattr(mission_module, "write_json_atomically", interrupted_on_step_two)
    mission = Mission(MissionConfig(preset="smoke", planner="stair", budget=3), out=tmp_path / "cut", preset=TINY)
    with pytest.raises(KeyboardInterrupt):
        mission.run()
    assert mission.saved_steps == 2 and len(json.loads((tmp_path / "cut" / "metrics.json").read_text())["steps"]) == 1
    monkeypatch.undo()
    resumed = run(tmp_path, "cut", budget=3, resume=True)
    assert strip_times(resumed) == strip_times(full)


def test_a_folder_in_use_is_refused_until_its_mission_ends(tmp_path):
    first = Mission(MissionConfig(preset="smoke", planner="uniform", budget=2), out=tmp_path / "x", preset=TINY)
    first.step()
    with pytest.raises(FolderInUseError, match=rf"in use by another mission \(process {os.getpid()}\)"):
        Mission(MissionConfig(preset="smoke", planner="uniform", budget=2), out=tmp_path / "x", preset=TINY, resume=True)
    first.step()  # the last step: the mission releases the folder
    assert len(run(tmp_path, "x", budget=3, planner="uniform", resume=True)) == 3
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError, match="is a file, not a folder"):
        run(tmp_path, "file", budget=1)


def test_a_fixed_pattern_mission_is_not_resumed_with_another_budget(tmp_path):
    """The fixed planner's spiral is spread for its budget: resuming with another would mix two spirals."""
    run(tmp_path, "f", budget=2, planner="fixed")
    with pytest.raises(ResultsFolderError, match="depends on the budget, so it cannot be resumed with budget 4"):
        run(tmp_path, "f", budget=4, planner="fixed", resume=True)
    assert len(run(tmp_path, "s", budget=2, planner="uniform")) == 2
    assert len(run(tmp_path, "s", budget=3, planner="uniform", resume=True)) == 3  # other planners may continue


def test_a_mission_on_an_edited_scene_file_is_not_resumed(tmp_path):
    scene = tmp_path / "mine.json"
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]}]}))
    Mission(MissionConfig(preset="smoke", scene=str(scene), planner="uniform", budget=1), out=tmp_path / "m", preset=TINY).run()
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.3, 0.0]}]}))
    with pytest.raises(ResultsFolderError, match="mine.json has changed since"):
        Mission(MissionConfig(preset="smoke", scene=str(scene), planner="uniform", budget=2), out=tmp_path / "m", preset=TINY,
                resume=True)


def test_a_full_disk_is_named_and_the_saved_steps_resume(tmp_path, monkeypatch):
    """On a full disk torch.save fails with "unexpected pos 64 vs 0": the error must name the file and the space
    left, leave no partial file behind, and the steps saved before must resume."""
    run(tmp_path, "x", budget=1, planner="uniform")
    from stair_lite import results_folder as mission_module

    def disk_full(state, path):
        open(path, "wb").close()
        raise RuntimeError("[enforce fail at inline_container.cc:672] . unexpected pos 64 vs 0")

    monkeypatch.setattr(mission_module.torch, "save", disk_full)
    with pytest.raises(OSError, match=r"could not write .*checkpoint.pt.tmp \([0-9.]+ MiB free on its disk: .*"
                                      r"the 1 steps saved before are kept, continue with --resume"):
        run(tmp_path, "x", budget=2, planner="uniform", resume=True)
    assert not (tmp_path / "x" / "checkpoint.pt.tmp").exists()
    monkeypatch.undo()
    assert len(run(tmp_path, "x", budget=2, planner="uniform", resume=True)) == 2


def test_scores_that_are_not_finite_are_written_as_json_null(tmp_path):
    from stair_lite.results_folder import write_json_atomically

    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    write_json_atomically(tmp_path / "m.json", {"steps": [{"psnr": float("inf"), "psnr_clean": float("nan"), "f1": 0.5,
                                                           "view_rad": (0.1, float("-inf"))}]})
    stored = json.loads((tmp_path / "m.json").read_text(), parse_constant=refuse)
    assert stored == {"steps": [{"psnr": None, "psnr_clean": None, "f1": 0.5, "view_rad": [0.1, None]}]}


def test_a_mission_stored_in_the_first_format_resumes(tmp_path):
    """Format 1 wrote no version and left out the label noise of an exact mission: ``upgrade_header`` reads it, and the
    resumed mission writes the current format."""
    full = run(tmp_path, "full", budget=3, planner="uniform")
    run(tmp_path, "old", budget=2, planner="uniform")
    path = tmp_path / "old" / "metrics.json"
    stored = json.loads(path.read_text())
    del stored["format"], stored["config"]["label_noise"]
    path.write_text(json.dumps(stored))
    resumed = run(tmp_path, "old", budget=3, planner="uniform", resume=True)
    assert strip_times(resumed) == strip_times(full)
    assert json.loads(path.read_text())["format"] == FORMAT
