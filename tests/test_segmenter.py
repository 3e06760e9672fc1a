"""The segmenter's noise model: each component's statistics against its parameters, on synthetic
measurements whose geometry is known in closed form."""
import numpy as np
import pytest

from stair_lite.classes import BACKGROUND, NUM_CLASSES, class_id
from stair_lite.geometry import Intrinsics
from stair_lite.measurement import Measurement
from stair_lite.segmenter import (LABEL_NOISE, LabelNoise, NoisySegmenter, add_blobs, bleed_boundaries, boundary_band,
                                  confuse_objects, confusion_matrix, corrupt_labels, grazing_image, label_error_rate,
                                  label_noise, miss_objects, miss_probability, object_regions)

CHAIR, SOFA, CAR = class_id("chair"), class_id("sofa"), class_id("car")


def plane_measurement(labels: np.ndarray, normal=(0.0, 0.0, -1.0), offset=2.0, fov=60.0) -> Measurement:
    """A camera at the origin (identity pose) looking at the plane n . X = -offset of the camera frame."""
    h, w = labels.shape
    k = Intrinsics.from_fov(w, h, fov)
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    d = np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, np.ones_like(u)], axis=-1)
    n = np.asarray(normal) / np.linalg.norm(normal)
    depth = -offset / (d @ n)  # z-depth of the ray's hit: t with t (d . n) = -offset, and d_z = 1
    return Measurement(rgb=np.zeros((h, w, 3), np.float32), depth=depth.astype(np.float32), labels=labels,
                       pose=np.eye(4), intrinsics=k)


def square(size=40, cls=CHAIR, lo=10, hi=30) -> np.ndarray:
    labels = np.zeros((size, size), dtype=np.int64)
    labels[lo:hi, lo:hi] = cls
    return labels


def within(count: int, n: int, p: float, sigmas: float = 4.0) -> bool:
    """A binomial count agrees with probability p (within ``sigmas`` standard deviations)."""
    return abs(count - n * p) <= sigmas * np.sqrt(n * p * (1 - p)) + 1e-9


def test_the_confusion_matrix_is_stochastic_and_keeps_background():
    c = confusion_matrix(0.3)
    assert np.allclose(c.sum(axis=1), 1.0) and (c >= 0).all()
    assert c[BACKGROUND, BACKGROUND] == 1.0
    assert c[CHAIR, CHAIR] == pytest.approx(0.7) and c[CHAIR, SOFA] == pytest.approx(0.18)
    assert np.array_equal(confusion_matrix(0.0), np.eye(NUM_CLASSES))


def test_the_grazing_angle_from_depth_matches_the_plane_in_closed_form():
    tilt = np.radians(50.0)
    normal = (np.sin(tilt), 0.0, -np.cos(tilt))
    m = plane_measurement(square(), normal=normal)
    distance, grazing = grazing_image(m)
    k = m.intrinsics
    u, v = np.meshgrid(np.arange(40) + 0.5, np.arange(40) + 0.5)
    d = np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, np.ones_like(u)], axis=-1)
    exact_cos = np.abs(d @ np.asarray(normal)) / np.linalg.norm(d, axis=-1)
    assert np.allclose(grazing[1:-1, 1:-1], 1 - exact_cos[1:-1, 1:-1], atol=1e-4)
    assert np.allclose(distance, m.depth * np.linalg.norm(d, axis=-1), rtol=1e-5)


def test_missed_detections_happen_at_the_rate_the_distance_and_angle_give():
    noise = LabelNoise(miss_base=0.05, miss_per_metre=0.3, miss_near=1.5, miss_grazing=0.4)
    assert miss_probability(noise, 1.0, 0.0) == pytest.approx(0.05)
    assert miss_probability(noise, 2.5, 0.5) == pytest.approx(0.05 + 0.3 + 0.2)
    assert miss_probability(noise, 9.0, 1.0) == 1.0
    rng = np.random.default_rng(0)
    for offset, normal in ((1.0, (0, 0, -1)), (2.5, (np.sin(0.9), 0, -np.cos(0.9)))):
        m = plane_measurement(square(), normal=normal, offset=offset)
        distance, grazing = grazing_image(m)
        region = m.labels == CHAIR
        p = miss_probability(noise, np.median(distance[region]), np.median(grazing[region]))
        trials = 800
        missed = sum(not (miss_objects(m.labels, m, noise, rng) == CHAIR).any() for _ in range(trials))
        assert within(missed, trials, p), (offset, missed, trials * p)
    kept = miss_objects(m.labels, m, noise, rng)
    assert set(np.unique(kept)) <= {BACKGROUND, CHAIR}  # a whole object goes, never part of it
    assert (kept == CHAIR).sum() in (0, (m.labels == CHAIR).sum())


def test_confusion_redraws_each_whole_object_from_its_row():
    labels = square(cls=CHAIR)
    labels[0:5, 0:5] = CAR  # a second object, confused independently
    noise, rng, trials = LabelNoise(confusion=0.3), np.random.default_rng(1), 3000
    reported = []
    for _ in range(trials):
        out = confuse_objects(labels, noise, rng)
        chair_values = np.unique(out[labels == CHAIR])
        assert len(chair_values) == 1 and (out[labels == BACKGROUND] == BACKGROUND).all()
        reported.append(chair_values[0])
    counts = np.bincount(reported, minlength=NUM_CLASSES)
    for cls, p in enumerate(confusion_matrix(0.3)[CHAIR]):
        assert within(counts[cls], trials, p), (cls, counts[cls], trials * p)


def brute_force_band(labels: np.ndarray, width: int) -> np.ndarray:
    h, w = labels.shape
    band = np.zeros_like(labels, dtype=bool)
    for r in range(h):
        for c in range(w):
            rr, cc = np.mgrid[0:h, 0:w]
            near = (rr - r) ** 2 + (cc - c) ** 2 <= width**2
            band[r, c] = (labels[near] != labels[r, c]).any()
    return band


def test_boundary_errors_stay_in_the_band_and_flip_at_its_rate():
    labels = square(size=24, lo=6, hi=18)
    labels[8:12, 8:12] = SOFA
    band, other = boundary_band(labels, 3)
    assert np.array_equal(band, brute_force_band(labels, 3))
    assert (other[band] != labels[band]).all() and np.array_equal(other[~band], labels[~band])
    noise, rng = LabelNoise(boundary_px=3, boundary_rate=0.4), np.random.default_rng(2)
    flipped = 0
    for _ in range(200):
        out = bleed_boundaries(labels, noise, rng)
        assert np.array_equal(out[~band], labels[~band])
        assert np.array_equal(out[out != labels], other[out != labels])  # a flip takes the nearest other label
        flipped += (out != labels).sum()
    assert within(flipped, 200 * band.sum(), 0.4)


def test_spurious_blobs_come_at_the_poisson_rate_with_object_classes():
    labels = np.zeros((200, 200), dtype=np.int64)
    noise, rng, trials = LabelNoise(blobs_per_image=0.5, blob_radius_px=(4.0, 6.0)), np.random.default_rng(3), 1500
    empty, single_areas = 0, []
    for _ in range(trials):
        out = add_blobs(labels, noise, rng)
        assert out.min() >= 0 and out.max() < NUM_CLASSES
        regions = object_regions(out)
        empty += not regions
        if len(regions) == 1:
            single_areas.append(regions[0][1].sum())
    assert within(empty, trials, np.exp(-0.5))
    mean_disc = np.pi * (6.0**3 - 4.0**3) / (3 * (6.0 - 4.0))  # E[pi r^2], r uniform in [4, 6]
    assert np.mean(single_areas) == pytest.approx(mean_disc, rel=0.1)  # discs cut by the border are rare


def test_the_segmenter_is_seeded_by_seed_and_step_and_exact_at_level_none():
    m = plane_measurement(square(size=80, lo=20, hi=60), offset=2.5)
    high = NoisySegmenter("high", seed=4)
    assert np.array_equal(high(m, 3).labels, NoisySegmenter("high", seed=4)(m, 3).labels)
    assert not np.array_equal(high(m, 3).labels, high(m, 4).labels)
    assert NoisySegmenter("none", seed=4)(m, 3) is m
    assert np.array_equal(high(m, 3).depth, m.depth) and np.array_equal(high(m, 3).rgb, m.rgb)
    with pytest.raises(ValueError, match="unknown label noise level 'loud'"):
        label_noise("loud")
    with pytest.raises(ValueError, match="confusion is a probability, got 1.5"):
        LabelNoise(confusion=1.5)
    with pytest.raises(ValueError, match="boundary_px must be a finite number >= 0, got -1"):
        LabelNoise(boundary_px=-1)


def test_the_named_levels_get_worse_in_order_on_a_rendered_view():
    from stair_lite.geometry import fibonacci_hemisphere, view_to_pose
    from stair_lite.scenes import load_scene
    from stair_lite.simulator import Simulator

    sim = Simulator(load_scene("scene1"), Intrinsics.from_fov(200, 200))
    views = [sim.render(view_to_pose(*v)) for v in fibonacci_hemisphere(4, azimuth_offset=0.3)]
    errors = {}
    for level in LABEL_NOISE:
        rng = np.random.default_rng(5)
        errors[level] = np.mean([label_error_rate(m.labels, corrupt_labels(m, LABEL_NOISE[level], rng))["wrong"]
                                 for m in views for _ in range(5)])
    assert errors["none"] == 0.0 < errors["low"] < errors["medium"] < errors["high"], errors
