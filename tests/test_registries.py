"""Planners, map kinds and metrics describe themselves and are registered once: a researcher's own planner runs from
its own file, and a metric registered in one place reaches the records, the results table, the report and the claims."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import stair_lite  # noqa: F401
from stair_lite.__main__ import main
from stair_lite.claims import claim_one
from stair_lite.experiments import SweepSpec, collect, read_table, run_sweep, summary, table_columns, write_table
from stair_lite.maps import MAP_KINDS, ReconstructionMap
from stair_lite.metrics import Metric, compared_metrics, register_metric, unregister_metric
from stair_lite.mission import Mission, MissionConfig
from stair_lite.results_folder import ResultsFolderError
from stair_lite.planners import PLANNERS, Planner, make_planner, register_planner
from stair_lite.config import get_preset

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "opposite_planner.py"


@pytest.fixture
def own_planner(tmp_path) -> str:
    """A copy of the README's example planner file, named as the command line takes it."""
    path = tmp_path / "opposite_planner.py"
    shutil.copy(EXAMPLE, path)
    return f"{path}:OppositePlanner"


def test_a_planner_from_its_own_file_runs_a_mission_and_its_file_is_recorded(tmp_path, own_planner, capsys):
    out = tmp_path / "run"
    assert main(["run", "--planner", own_planner, "--preset", "smoke", "--budget", "3", "--out", str(out), "--quiet"]) == 0
    stored = json.loads((out / "metrics.json").read_text())
    assert stored["config"]["planner"] == own_planner and len(stored["steps"]) == 3
    assert len(stored["planner_file_sha256"]) == 64
    views = np.array([r["view_rad"] for r in stored["steps"]])
    assert np.abs(np.angle(np.exp(1j * (views[2, 1] - views[1, 1])))) > 2.0  # it plans as written: the opposite side
    # the file changes: the stored mission is not continued with other code
    path = Path(own_planner.rpartition(":")[0])
    path.write_text(path.read_text() + "\n# edited\n")
    with pytest.raises(ResultsFolderError, match="planner file .* has changed since"):
        Mission(MissionConfig(planner=own_planner, preset="smoke", budget=4), out=out, resume=True)


def test_a_planner_from_its_own_file_runs_in_a_sweep_and_an_edit_is_refused(tmp_path, own_planner):
    spec = SweepSpec(("scene1",), ("uniform", own_planner), (0,), preset="smoke", budget=2)
    outcomes = run_sweep(spec, tmp_path, progress=False)
    assert sorted(o for _, o in outcomes) == ["ran", "ran"]
    assert {r["variant"] for r in collect(tmp_path)} == {"uniform", "opposite_planner.OppositePlanner"}
    assert "opposite_planner.OppositePlanner" in json.loads((tmp_path / "sweep.json").read_text())["planner_files"]
    path = Path(own_planner.rpartition(":")[0])
    path.write_text(path.read_text() + "\n# edited\n")
    with pytest.raises(ValueError, match="planner files .*opposite_planner.OppositePlanner.* content has changed"):
        run_sweep(spec, tmp_path, progress=False)


@pytest.mark.parametrize("name, message", [
    ("missing.py:Planner", "does not exist"),
    ("{example}:NoSuchClass", "defines no subclass of stair_lite.planners.Planner named NoSuchClass"),
    ("{example}:Decision", "defines no subclass"),  # a class, but not a planner
])
def test_a_bad_planner_file_is_named(name, message):
    with pytest.raises(ValueError, match=message):
        MissionConfig(planner=name.format(example=EXAMPLE), preset="smoke")


def test_every_registered_planner_builds_from_the_preset_and_declares_its_columns():
    preset = get_preset("smoke")
    for name, entry in PLANNERS.items():
        planner = make_planner(name, preset, seed=0)
        assert isinstance(planner, entry.cls) and planner.name == name
        assert planner.reads in (None, *MAP_KINDS)
        assert all(isinstance(c, str) for c in planner.score_columns)
    with pytest.raises(ValueError, match="taken"):
        register_planner("stair", Planner)
    for kind, cls in MAP_KINDS.items():
        assert issubclass(cls, ReconstructionMap) and cls.kind == kind
        assert cls.from_preset(preset, seed=0).kind == kind


def test_semantic_uncertainty_reaches_the_results_table(tmp_path):
    run_sweep(SweepSpec(("scene1",), ("stair",), (0,), preset="smoke", budget=2), tmp_path, progress=False)
    table = read_table(write_table(collect(tmp_path), tmp_path / "results.csv"))
    assert "semantic_uncertainty" in table[0] and table[1]["semantic_uncertainty"] is not None
    assert table[0]["semantic_uncertainty"] is None  # no plan before the top view


@pytest.fixture
def dummy_metric():
    """A metric registered in one place, computed from the evaluation (a constant: easy to find everywhere)."""
    metric = register_metric(Metric("dummy", "a dummy metric", lower_is_better=True, digits=1,
                                    compute=lambda evaluation, reconstruction: evaluation["psnr"] * 0 + 7.0))
    yield metric
    unregister_metric("dummy")


def test_a_registered_metric_reaches_records_table_report_and_claims(tmp_path, dummy_metric, capsys):
    assert "dummy" in compared_metrics() and "dummy" in table_columns()
    spec = SweepSpec(("scene1",), ("stair", "exploration", "fixed", "max_distance", "uniform"), (0, 1), preset="smoke",
                     budget=2)
    run_sweep(spec, tmp_path, progress=False)
    stored = json.loads((tmp_path / "scene1" / "stair" / "seed0" / "metrics.json").read_text())
    assert all(r["dummy"] == 7.0 for r in stored["steps"])  # the mission's records
    rows = read_table(write_table(collect(tmp_path), tmp_path / "results.csv"))
    assert all(r["dummy"] == 7.0 for r in rows)  # the results table
    assert all(e["dummy_auc_mean"] == 7.0 for e in summary(rows, compared_metrics()))  # the summary
    assert main(["report", "--results", str(tmp_path)]) == 0
    header = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("scene "))
    assert "dummy" in header.split() and (tmp_path / "curves_dummy.png").exists()  # the report
    comparison = next(c for c in claim_one(rows) if c.metric == "dummy")  # the claims
    assert comparison.describe().startswith("scene1 dummy: stair 7.0 +- 0.0")
