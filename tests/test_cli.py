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
    (["run", "--epsilon", "inf"], "epsilon must be a finite number >= 0, got inf"),
    (["sweep", "--workers", "0"], "--workers must be at least 1, got 0"),
    (["sweep", "--workers", "-1"], "--workers must be at least 1, got -1"),
    (["run", "--seed", str(10**20)], f"seed must be a whole number from 0 to 2**32 - 1, got {10**20}"),
    (["sweep", "--first-seed", str(2**32)], f"--first-seed must be from 0 to 2**32 - --seeds, got {2**32}"),
])
def test_bad_settings_are_refused_in_one_line(tmp_path, capsys, argv, message):
    assert main(argv + ["--out", str(tmp_path / "out"), "--preset", "smoke"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_scenes_describes_a_scene_file(tmp_path, capsys):
    scene = tmp_path / "mine.json"
    scene.write_text(json.dumps({"targets": ["car"], "objects": [{"class": "car", "position": [0.0, 0.0]},
                                                                 {"class": "chair", "position": [0.5, 0.0]}]}))
    assert main(["scenes", str(scene)]) == 0
    out = capsys.readouterr().out
    assert "mine.json" in out and "targets: car" in out and "2 objects (car, chair)" in out


@pytest.mark.parametrize("argv, message", [
    (["fit", "--iterations", "0"], "--iterations must be at least 1, got 0"),
    (["fit", "--rays", "0"], "--rays must be at least 1, got 0"),
    (["fit", "--views", "0"], "--views must be at least 1, got 0"),
])
def test_fit_refuses_an_empty_schedule(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("content", ["not json", '{"steps": 5}', '{"steps": [{"view_rad": "x"}]}', '[1]'])
def test_a_garbage_replay_file_is_named(tmp_path, capsys, content):
    replay = tmp_path / "garbage.json"
    replay.write_text(content)
    code = main(["run", "--planner", "replay", "--replay", str(replay), "--preset", "smoke", "--budget", "1",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "garbage.json is not a mission's metrics.json" in err and "Traceback" not in err


@pytest.mark.parametrize("argv", [["run", "--preset", "smoke", "--budget", "1"], ["render"],
                                  ["sweep", "--preset", "smoke", "--budget", "1", "--scenes", "scene1", "--planners", "uniform"]])
def test_an_output_folder_under_a_file_is_named(tmp_path, capsys, argv):
    (tmp_path / "file").write_text("")
    assert main(argv + ["--out", str(tmp_path / "file" / "out")]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'file' / 'out'}" in err and "Not a directory" in err and "Traceback" not in err


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
