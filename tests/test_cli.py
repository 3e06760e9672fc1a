"""The command line refuses bad input with one line naming the problem and the value, and writes where it is told."""
import json

import pytest

from stair_lite.__main__ import main


def test_render_of_a_scene_file_writes_into_the_output_folder(tmp_path, capsys):
    scene = tmp_path / "scenes" / "mine.json"
    scene.parent.mkdir()
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]}]}))
    assert main(["render", "--scene", str(scene), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "mine_views.png").exists() and not list(scene.parent.glob("*.png"))


@pytest.mark.parametrize("argv, message", [
    (["run", "--budget", "60"], "budget must be a whole number of measurements from 1 to 50, got 60"),
    (["run", "--epsilon", "inf"], "epsilon must be a number from 0 to 1e+06, got inf"),
    (["run", "--epsilon", "1e39"], "epsilon must be a number from 0 to 1e+06, got 1e+39"),  # float32 overflow
    (["sweep", "--planners", "stair_eps1e308"], "planner variant 'stair_eps1e308': epsilon must be a number from 0"),
    (["sweep", "--planners", "stair_epsinf"], "planner variant 'stair_epsinf': epsilon must be a number from 0"),
    (["sweep", "--workers", "0"], "--workers must be at least 1, got 0"),
    (["sweep", "--workers", "-1"], "--workers must be at least 1, got -1"),
    (["run", "--seed", str(10**20)], f"argument --seed: a seed is from 0 to {2**32 - 1}, got {10**20}"),
    (["fit", "--seed", "-1"], "argument --seed: a seed is from 0 to 4294967295, got -1"),
    (["fit", "--rays", "1000000000"], "--rays must be between 1 and 65536, got 1000000000"),
    (["headroom", "--candidates", "100000"], "2 to 128 candidates and 1 to 8 streams, got after=3, candidates=100000"),
    (["sweep", "--first-seed", str(2**32 - 1)], f"--first-seed must be from 0 to {2**32} - --seeds, got {2**32 - 1}"),
])
def test_bad_settings_are_refused_in_one_line(tmp_path, capsys, argv, message):
    try:
        status = main(argv + ["--out", str(tmp_path / "out"), "--preset", "smoke"])
    except SystemExit as stop:  # argparse's refusal of an option's value
        status = stop.code
    assert status == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()  # refused before anything is written


def test_scenes_describes_a_scene_file(tmp_path, capsys):
    scene = tmp_path / "mine.json"
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]},
                                                                 {"class": "chair", "position": [0.9, 0.0]}]}))
    assert main(["scenes", str(scene)]) == 0
    out = capsys.readouterr().out
    assert "mine.json" in out and "targets: car" in out and "2 objects (car, chair)" in out


@pytest.mark.parametrize("change, message", [
    ({"scale": -1}, "object 0 (car): scale must be positive, got -1"),
    ({"position": [1e300, 0.0]}, "extends outside the scene cube"),
    ({"mesh": "teapot"}, "mesh source 'teapot' is neither 'procedural'"),
])
def test_scenes_refuses_a_scene_file_that_run_refuses(tmp_path, capsys, change, message):
    scene = tmp_path / "mine.json"
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0], **change}]}))
    assert main(["scenes", str(scene)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert main(["run", "--scene", str(scene), "--preset", "smoke", "--budget", "1", "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err  # the same refusal


@pytest.mark.parametrize("argv, message", [
    (["fit", "--iterations", "0"], "--iterations must be between 1 and 20000, got 0"),
    (["fit", "--rays", "0"], "--rays must be between 1 and 65536, got 0"),
    (["fit", "--views", "0"], "--views must be between 1 and 500, got 0"),
])
def test_fit_refuses_an_empty_schedule(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("option", ["--iterations", "--rays"])
def test_fit_refuses_a_training_schedule_for_the_voxel_map(capsys, option):
    assert main(["fit", "--mapper", "explicit", option, "10"]) == 2
    err = capsys.readouterr().err
    assert "--iterations and --rays set the field's training: the explicit map trains nothing" in err
    assert "Traceback" not in err


def test_fit_of_the_voxel_map_reports_the_scores_its_evaluator_gives(capsys):
    """``fit --mapper explicit`` integrates the spread views into the voxel map and prints the evaluator's scores:
    the same figures as integrating those views by hand and evaluating."""
    from stair_lite.config import get_preset
    from stair_lite.geometry import fibonacci_hemisphere
    from stair_lite.mission import World, build_map

    assert main(["fit", "--mapper", "explicit", "--preset", "smoke", "--views", "3"]) == 0
    printed = capsys.readouterr().out
    preset = get_preset("smoke")
    world = World.build("scene1", preset)
    voxels = build_map("explicit", preset)
    for step, view in enumerate(fibonacci_hemisphere(3, azimuth_offset=0.3), start=1):
        voxels.integrate(world.measure(view, step))
    result = world.evaluator.evaluate(voxels)
    assert "explicit map" in printed and "integration" in printed and "loss" not in printed
    assert (f"F1 {result['f1']:.3f} (1 cm" in printed and f"f1_5cm {result['f1_5cm']:.3f}" in printed
            and f"chamfer {result['chamfer'] * 100:.2f} cm" in printed), printed


@pytest.mark.parametrize("content", ["not json", '{"steps": 5}', '{"steps": [{"view_rad": "x"}]}', '[1]'])
def test_a_garbage_replay_file_is_named(tmp_path, capsys, content):
    replay = tmp_path / "garbage.json"
    replay.write_text(content)
    code = main(["run", "--planner", "replay", "--replay", str(replay), "--preset", "smoke", "--budget", "1",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "garbage.json is not a mission's metrics.json" in err and "Traceback" not in err


@pytest.mark.parametrize("views, message", [
    ([[1.5707963, 0.0], [True, False]], "the view of step 2, [True, False], is not an (elevation, azimuth) pair of numbers"),
    ([[1.5707963, 0.0], [0.3]], "the view of step 2, [0.3], is not an (elevation, azimuth) pair"),
    ([[1.5707963, 0.0], [-0.4, 1.0]], "the view of step 2 has elevation -0.4 rad, off the hemisphere [0, pi/2]"),
    ([[1.5707963, 0.0], [2.0, 1.0]], "the view of step 2 has elevation 2.0 rad, off the hemisphere"),
])
def test_replayed_views_are_checked_before_the_mission_starts(tmp_path, capsys, views, message):
    replay = tmp_path / "views.json"
    replay.write_text(json.dumps({"steps": [{"view_rad": v} for v in views]}))
    code = main(["run", "--planner", "replay", "--replay", str(replay), "--preset", "smoke", "--budget", "2",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "out" / "metrics.json").exists()  # refused before step 1


COMMANDS_THAT_WRITE = [["run", "--preset", "smoke", "--budget", "1"], ["render"],
                       ["sweep", "--preset", "smoke", "--budget", "1", "--scenes", "scene1", "--planners", "uniform"],
                       ["fit", "--views", "1"],
                       ["headroom", "--preset", "smoke", "--after", "1", "--candidates", "2"]]


@pytest.mark.parametrize("argv", COMMANDS_THAT_WRITE, ids=lambda argv: argv[0])
@pytest.mark.parametrize("where", ["a file", "under a file"])
def test_an_output_folder_that_is_a_file_is_refused_before_any_work(tmp_path, capsys, monkeypatch, argv, where):
    import stair_lite.simulator

    def no_work(*args, **kwargs):
        raise AssertionError("the command started working before it checked its output folder")

    monkeypatch.setattr(stair_lite.simulator.Simulator, "__init__", no_work)
    (tmp_path / "file").write_text("")
    out = tmp_path / "file" if where == "a file" else tmp_path / "file" / "out"
    assert main(argv + ["--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"cannot write results into {out}: {tmp_path / 'file'} is a file, not a folder" in err
    assert "Traceback" not in err and "Errno" not in err


@pytest.mark.parametrize("argv", COMMANDS_THAT_WRITE, ids=lambda argv: argv[0])
def test_an_output_folder_that_cannot_be_written_is_refused(tmp_path, capsys, monkeypatch, argv):
    import os

    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode: False if str(path).startswith(str(tmp_path)) else real_access(path, mode))
    assert main(argv + ["--out", str(tmp_path / "out")]) == 2  # (the tests may run as root, whom chmod does not stop)
    err = capsys.readouterr().err
    assert f"cannot write into the folder {tmp_path / 'out'}: it is read-only" in err and "Traceback" not in err


@pytest.mark.parametrize("command", ["run", "sweep", "fit"])
def test_label_noise_is_an_option_of_run_sweep_and_fit(capsys, command):
    with pytest.raises(SystemExit):  # argparse names the value and the choices
        main([command, "--label-noise", "loud"])
    assert "--label-noise: invalid choice: 'loud' (choose from 'none', 'low', 'medium', 'high')" in capsys.readouterr().err


def test_a_noisy_mission_from_the_command_line_says_so_and_stores_its_level(tmp_path, capsys):
    assert main(["run", "--preset", "smoke", "--budget", "1", "--label-noise", "medium", "--quiet",
                 "--out", str(tmp_path)]) == 0
    assert "label noise medium" in capsys.readouterr().out
    assert json.loads((tmp_path / "metrics.json").read_text())["config"]["label_noise"] == "medium"
