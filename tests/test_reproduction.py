"""The stored sweep results are reproducible: re-running a stored cell gives its stored metrics.

Sweep cells run with one torch thread per worker (``run_sweep`` with ``--workers 2``), and float sums
depend on the thread count, so these tests pin one thread. Tolerances: views to 1e-6 deg, PSNR to
0.05 dB, F1 to 0.01 (the same machine type and software versions reproduce them exactly; the
tolerances leave room for another CPU's vector instructions).
"""
import json
from pathlib import Path

import pytest
import torch

from stair_lite.experiments import Cell, mission_config
from stair_lite.mission import Mission

STORED = Path(__file__).resolve().parents[1] / "data" / "results" / "sweep_lite"


@pytest.fixture
def one_thread():
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def rerun(cell: Cell, budget: int, out: Path) -> tuple[list[dict], list[dict]]:
    """(stored steps, re-run steps) of the first ``budget`` steps of a stored cell."""
    stored = json.loads((cell.folder(STORED) / "metrics.json").read_text())
    config = mission_config(cell, STORED, stored["config"]["preset"], budget)
    assert config.budget == budget and stored["config"]["seed"] == cell.seed
    records = Mission(config, out=out).run()
    return stored["steps"][:budget], records


def assert_same_steps(stored: list[dict], records: list[dict]) -> None:
    assert len(records) == len(stored)
    for old, new in zip(stored, records):
        assert new["view_deg"] == pytest.approx(old["view_deg"], abs=1e-6), f"step {old['step']}: another view"
        assert new["psnr"] == pytest.approx(old["psnr"], abs=0.05), f"step {old['step']}: PSNR"
        assert new["f1"] == pytest.approx(old["f1"], abs=0.01), f"step {old['step']}: F1"


def test_stored_ste_cell_reproduces(tmp_path, one_thread):
    """The whole explicit-baseline mission: all 10 steps."""
    assert_same_steps(*rerun(Cell("scene1", "ste", 0), 10, tmp_path))


def test_stored_stair_cell_reproduces_its_first_steps(tmp_path, one_thread):
    """STAIR's first three steps (the top view and two planned views, each after training on the
    field); the full cell takes about 2.5 minutes on one thread."""
    assert_same_steps(*rerun(Cell("scene1", "stair", 0), 3, tmp_path))
