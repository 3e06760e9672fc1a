"""The paper-scale study scripts pass their arguments through to the command line (a stand-in interpreter records the
commands instead of running missions)."""
import os
import stat
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def recording_python(tmp_path):
    """An executable that appends its arguments to a log, one line per call, and exits 0."""
    log = tmp_path / "calls.log"
    stub = tmp_path / "python"
    stub.write_text(f'#!/usr/bin/env bash\necho "$*" >> "{log}"\n')
    stub.chmod(stub.stat().st_mode | stat.S_IEXEC)
    return stub, log


def run_script(name, args, stub):
    env = {**os.environ, "PY": str(stub)}
    subprocess.run(["bash", str(ROOT / "scripts" / name), *args], env=env, check=True, timeout=60)


def test_the_paper_comparison_runs_every_scene_of_each_seed_into_the_folder_given(recording_python, tmp_path):
    stub, log = recording_python
    run_script("paper_comparison.sh", ["2", "2", "cuda", str(tmp_path / "gpu" / "comparison_paper")], stub)
    calls = log.read_text().splitlines()
    assert len(calls) == 8  # 2 seeds x 4 scenes
    for call in calls:
        assert f"--out {tmp_path / 'gpu' / 'comparison_paper'}" in call and "--device cuda" in call
        assert "--preset paper" in call
    assert sorted(c.split("--first-seed ")[1].split()[0] for c in calls) == ["0"] * 4 + ["1"] * 4
    assert {c.split("--scenes ")[1].split()[0] for c in calls} == {"scene1", "scene2", "scene3", "scene4"}


def test_the_paper_comparison_defaults_to_the_stored_study(recording_python):
    stub, log = recording_python
    run_script("paper_comparison.sh", ["1", "1"], stub)
    calls = log.read_text().splitlines()
    assert len(calls) == 4 and all("--out data/results/comparison_paper" in c and "--device cpu" in c for c in calls)


def test_the_paper_headroom_writes_both_tables_into_the_folder_given(recording_python, tmp_path):
    stub, log = recording_python
    run_script("paper_headroom.sh", ["cuda", str(tmp_path / "league")], stub)
    calls = log.read_text().splitlines()
    assert sorted(c.split("--scene ")[1].split()[0] for c in calls) == ["scene1", "scene4"]
    assert all(f"--out {tmp_path / 'league'}" in c and "--device cuda" in c for c in calls)
    run_script("paper_headroom.sh", [], stub)
    assert all("--out data/results/headroom_league_paper" in c for c in log.read_text().splitlines()[2:])
