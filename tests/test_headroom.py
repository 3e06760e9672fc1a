"""The headroom instrument: realised gains of candidate next views on copies of a mission's map."""
import numpy as np
import pytest

from stair_lite.headroom import (Headroom, _finished_rows, add_utilities, measure_headroom, noise_ceiling,
                                 ranking_planners)
from stair_lite.mission import Mission, MissionConfig


@pytest.fixture(scope="module")
def headroom():
    return measure_headroom("scene1", after=2, n_candidates=5, seed=0, preset="smoke", log=lambda line: None)


def test_the_stair_pick_realises_what_the_mission_measures_next(headroom):
    """Independent check of "added to a copy of the map, trained the same way": the copy given STAIR's pick
    ends exactly where an uninterrupted mission one view longer ends."""
    longer = Mission(MissionConfig(scene="scene1", planner="stair", seed=0, preset="smoke", budget=3)).run()
    (pick,) = [r for r in headroom.rows if r["kind"] == "stair"]
    assert np.allclose([pick["elevation_deg"], pick["azimuth_deg"]], longer[-1]["view_deg"])
    for metric in headroom.metrics:
        assert pick[metric] == pytest.approx(longer[-1][metric], abs=1e-9), metric
        assert headroom.before[metric] == pytest.approx(longer[-2][metric], abs=1e-9), metric


def test_rows_gains_and_correlations(headroom, tmp_path):
    spread = [r for r in headroom.rows if r["kind"] == "spread"]
    assert 2 <= len(spread) <= 5 and [r["kind"] for r in headroom.rows[len(spread):]] == list(headroom.utilities)
    assert headroom.utilities == ranking_planners() and {"stair", "exploration", "max_distance"} <= set(headroom.utilities)
    for r in headroom.rows:
        assert r["gain_psnr"] == pytest.approx(r["psnr"] - headroom.before["psnr"])
        assert r["gain_chamfer"] == pytest.approx(headroom.before["chamfer"] - r["chamfer"])  # a gain is a reduction
    for u in headroom.utilities:
        for m in headroom.metrics:
            rho = headroom.correlations[u][m]
            assert rho is None or -1.0 <= rho <= 1.0
    assert 0.0 <= headroom.pick_percentile("stair", "psnr") <= 1.0
    loaded = Headroom.load(headroom.save(tmp_path))
    assert loaded.correlations == headroom.correlations and loaded.rows == headroom.rows


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="at least 1 view before, 2 to 128 candidates"):
        measure_headroom("scene1", after=0, n_candidates=5, preset="smoke")


def test_a_stopped_headroom_run_keeps_its_finished_views_and_continues_from_them(tmp_path):
    """The views realised before an interruption are kept in the progress file; the next run realises only the
    others, and the table equals an uninterrupted run's."""
    whole = measure_headroom("scene1", after=1, n_candidates=4, preset="smoke", utilities=("stair",), log=lambda _: None)
    progress = tmp_path / "scene1_after1.partial.jsonl"
    calls = []

    def stop_after_two(line):
        calls.append(line)
        if len(calls) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        measure_headroom("scene1", after=1, n_candidates=4, preset="smoke", utilities=("stair",), log=stop_after_two,
                         progress=progress)
    assert len(progress.read_text().splitlines()) == 1 + 2  # the header and two realised views
    realised = []
    resumed = measure_headroom("scene1", after=1, n_candidates=4, preset="smoke", utilities=("stair",),
                               log=realised.append, progress=progress)
    assert len(realised) == len(whole.rows) - 2 and resumed.rows == whole.rows
    with pytest.raises(ValueError, match="finished views of another headroom table"):
        _finished_rows(progress, {"scene": "scene1", "after": 1, "candidates": 5})


def test_the_noise_ceiling_is_perfect_for_identical_streams_and_lower_for_noisy_ones():
    gains = np.tile(np.arange(8.0), (3, 1))
    assert noise_ceiling(gains) == {"spearman": 1.0, "pick_percentile": 7 / 8}  # the oracle's pick beats 7 of 8
    noisy = gains + np.random.default_rng(0).normal(0, 3.0, gains.shape)
    ceiling = noise_ceiling(noisy)
    assert ceiling["spearman"] < 0.95 and ceiling["pick_percentile"] <= 7 / 8


def test_adding_a_utility_to_a_stored_table_equals_measuring_it_with_the_others():
    """The league grows by utility without realising the spread views again: the mission is seeded, so the added
    planner's pick and every score come out as in one measurement of both."""
    both = measure_headroom("scene1", after=2, n_candidates=3, seed=0, preset="smoke",
                            utilities=("stair", "exploration"), log=lambda line: None)
    one = measure_headroom("scene1", after=2, n_candidates=3, seed=0, preset="smoke", utilities=("stair",),
                           log=lambda line: None)
    grown = add_utilities(one, ("exploration",), log=lambda line: None)
    assert grown.utilities == both.utilities and grown.correlations == both.correlations
    assert [sorted(r.items()) for r in grown.rows] == [sorted(r.items()) for r in both.rows]
    # a table whose mission the current code no longer reaches (another code or thread count) is refused, not grown
    from dataclasses import replace

    elsewhere = replace(one, before={**one.before, "f1": one.before["f1"] + 0.01})
    with pytest.raises(ValueError, match="no longer reaches the table's state"):
        add_utilities(elsewhere, ("exploration",), log=lambda line: None)
