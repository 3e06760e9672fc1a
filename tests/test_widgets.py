"""The mission explorer builds and redraws without a display, from small fake records."""
import matplotlib

matplotlib.use("Agg")
import numpy as np
import pytest

from stair_lite.geometry import fibonacci_hemisphere, view_to_pose
from stair_lite.widgets import MissionExplorer, mission_explorer, plot_mission_steps, step_summary


def fake_mission(n=4, seed=0):
    rng = np.random.default_rng(seed)
    views = [(np.pi / 2, 0.0)] + [(rng.uniform(0.2, 1.3), rng.uniform(0, 2 * np.pi)) for _ in range(n - 1)]
    records, snapshots = [], []
    for i, v in enumerate(views):
        first = i == 0
        records.append({
            "step": i + 1, "view_rad": list(v), "view_deg": list(np.degrees(v)), "pose": view_to_pose(*v).tolist(),
            "psnr": 12.0 + i, "precision": 0.1 * i, "completeness": 0.05 * i, "f1": 0.07 * i,
            "utility": None if first else 10.0 + i, "exploitation": None if first else 6.0 + i,
            "exploration": None if first else 20.0,
        })
        cand = fibonacci_hemisphere(30, azimuth_offset=0.1 * i)
        snapshots.append({"image": rng.uniform(size=(8, 8, 3)), "views": cand, "values": rng.uniform(size=30)})
    return records, snapshots


def test_explorer_builds_and_starts_at_the_last_step():
    records, snapshots = fake_mission()
    w = mission_explorer(records, snapshots=snapshots)
    assert isinstance(w, MissionExplorer)
    assert w.slider.min == 1 and w.slider.max == 4 and w.slider.value == 4
    assert w.slider.continuous_update is False
    assert w.step == 4 and w.n_draws == 1
    assert "step 4/4" in w.summary.value
    assert w.children == (w.slider, w.summary, w.output)


def test_slider_change_runs_the_callback_and_redraws():
    records, snapshots = fake_mission()
    w = mission_explorer(records, snapshots=snapshots)
    w.slider.value = 2
    assert w.step == 2 and w.n_draws == 2
    assert "step 2/4" in w.summary.value and "PSNR 13.00 dB" in w.summary.value
    # the map shows the views measured up to step 2 and the next one; the image panel shows snapshot 2
    ax_map, ax_img = w.figure.axes[:2]
    path = [line for line in ax_map.get_lines() if line.get_label() == "measured"][0]
    assert len(path.get_xdata()) == 2
    assert np.allclose(ax_img.get_images()[0].get_array(), snapshots[1]["image"])
    w.slider.value = 1  # the top view: no planner scores yet
    assert w.step == 1 and w.n_draws == 3 and "U -" in w.summary.value


def test_explorers_keep_their_own_state():
    records, snapshots = fake_mission()
    a, b = mission_explorer(records, snapshots=snapshots), mission_explorer(records)
    a.slider.value = 1
    assert a.step == 1 and b.step == 4 and b.n_draws == 1


def test_explorer_rejects_mismatched_snapshots():
    records, snapshots = fake_mission()
    with pytest.raises(ValueError, match="one per step"):
        mission_explorer(records, snapshots=snapshots[:2])
    with pytest.raises(ValueError, match="at least one"):
        mission_explorer([])


def test_static_fallback_has_a_panel_per_step():
    records, snapshots = fake_mission(n=5)
    fig = plot_mission_steps(records, snapshots)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title().startswith("step")]
    assert len(titles) == 5 and titles[0].startswith("step 1:")
    bars = [ax for ax in fig.axes if ax.get_ylabel().startswith("utility of a candidate view")]
    assert len(bars) == 1  # one colour bar for every step's map (utilities as shares of the step's largest)
    assert step_summary(records, 3).startswith("step 3/5")
    matplotlib.pyplot.close(fig)


def test_grading_shows_the_explorer_as_its_static_figure(monkeypatch):
    """Under STAIR_STATIC_WIDGETS=1 (set while grading) the explorer is the figure of every step, no live widget."""
    records, snapshots = fake_mission(n=4)
    assert isinstance(mission_explorer(records, snapshots=snapshots), MissionExplorer)
    monkeypatch.setenv("STAIR_STATIC_WIDGETS", "1")
    fig = mission_explorer(records, snapshots=snapshots)
    assert isinstance(fig, matplotlib.figure.Figure) and len([ax for ax in fig.axes if ax.get_title().startswith("step")]) == 4
    matplotlib.pyplot.close(fig)


def test_top_down_views_put_each_view_at_cos_elevation_from_the_centre_and_number_them():
    from stair_lite.plotting import plot_views_top_down

    records, _ = fake_mission(n=6)
    fig, ax = matplotlib.pyplot.subplots()
    plot_views_top_down(ax, records, "six views")
    numbers = {t.get_text(): t.xy for t in ax.texts if t.get_text().isdigit()}
    assert sorted(numbers, key=int) == [str(k) for k in range(1, 7)]
    for k, record in enumerate(records, start=1):
        elevation, azimuth = record["view_rad"]
        x, y = numbers[str(k)]
        assert np.isclose(np.hypot(x, y), np.cos(elevation), atol=1e-9)  # the rings read elevation off the radius
        if k > 1:
            assert np.isclose(np.arctan2(y, x) % (2 * np.pi), azimuth % (2 * np.pi), atol=1e-9)
    assert {t.get_text() for t in ax.texts} >= {"0 deg", "30 deg", "60 deg"}
    matplotlib.pyplot.close(fig)
