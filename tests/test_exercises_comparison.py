"""The checkers of notebook 06's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest
import torch
from scipy import stats

from stair_lite.exercises.comparison import check_octomap_update, check_paired_p_value
from stair_lite.explicit import octomap_update


def paired_ok(a, b):
    return stats.ttest_rel(a, b).pvalue


def paired_welch(a, b):
    return stats.ttest_ind(a, b, equal_var=False).pvalue


def paired_student(a, b):
    return stats.ttest_ind(a, b, equal_var=True).pvalue


def paired_one_sided(a, b):
    return stats.ttest_rel(a, b).pvalue / 2


def paired_ddof0(a, b):
    d = a - b
    return 2 * stats.t.sf(abs(d.mean() / (d.std() / np.sqrt(len(d)))), len(d) - 1)


def paired_normal(a, b):
    d = a - b
    return 2 * stats.norm.sf(abs(d.mean() / (d.std(ddof=1) / np.sqrt(len(d)))))


def stub(a, b):
    raise NotImplementedError


def paired_doubled_cdf(a, b):  # 2 * cdf(|t|): a number above 1
    d = a - b
    return 2 * stats.t.cdf(abs(d.mean() / (d.std(ddof=1) / np.sqrt(len(d)))), len(d) - 1)


def test_a_correct_paired_test_passes():
    assert check_paired_p_value(paired_ok)


@pytest.mark.parametrize("wrong,hint", [(paired_welch, "unpaired"), (paired_student, "unpaired"),
                                        (paired_one_sided, "two-sided"), (paired_ddof0, "ddof=1"),
                                        (paired_normal, "normal distribution"), (stub, "NotImplementedError"),
                                        (lambda a, b: 0.5, "expected"),
                                        (paired_doubled_cdf, "no probability")])
def test_wrong_paired_tests_are_caught_with_a_hint(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_paired_p_value(wrong)


# ---------------------------------------------------------------------------------------- the OctoMap update
def octomap_ok(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):
    free = np.setdiff1d(crossed, hit)
    log_odds[free] = np.clip(log_odds[free] + l_miss, l_min, l_max)
    hit = np.unique(hit)
    log_odds[hit] = np.clip(log_odds[hit] + l_hit, l_min, l_max)
    return log_odds


def octomap_add_at(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):  # every ray counts
    free = crossed[~np.isin(crossed, hit)]
    np.add.at(log_odds, free, l_miss)
    np.add.at(log_odds, hit, l_hit)
    return np.clip(log_odds, l_min, l_max)


def octomap_both(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):  # crossed-and-hit voxels also freed
    crossed, hit = np.unique(crossed), np.unique(hit)
    log_odds[crossed] = np.clip(log_odds[crossed] + l_miss, l_min, l_max)
    log_odds[hit] = np.clip(log_odds[hit] + l_hit, l_min, l_max)
    return log_odds


def octomap_no_clamp(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):
    log_odds[np.setdiff1d(crossed, hit)] += l_miss
    log_odds[np.unique(hit)] += l_hit
    return log_odds


def octomap_subtract_miss(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):
    free = np.setdiff1d(crossed, hit)
    log_odds[free] = np.clip(log_odds[free] - l_miss, l_min, l_max)
    log_odds[np.unique(hit)] = np.clip(log_odds[np.unique(hit)] + l_hit, l_min, l_max)
    return log_odds


def octomap_overwrite(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):
    log_odds[np.setdiff1d(crossed, hit)] = l_miss
    log_odds[np.unique(hit)] = l_hit
    return log_odds


def octomap_probability(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):  # probabilities, not log-odds
    p = 1 / (1 + np.exp(-log_odds))
    p[np.setdiff1d(crossed, hit)] *= 0.4
    p[np.unique(hit)] *= 0.7
    return np.log(p / (1 - p))


def octomap_stub(*args):
    raise NotImplementedError


def test_a_correct_octomap_update_passes():
    assert check_octomap_update(octomap_ok)


@pytest.mark.parametrize("wrong,hint", [(octomap_add_at, "at most once per scan"), (octomap_both, "counts as hit only"),
                                        (octomap_no_clamp, "clamp"), (octomap_subtract_miss, "already negative"),
                                        (octomap_overwrite, r"\+="), (octomap_probability, "expected"),
                                        (lambda *args: None, "None"), (octomap_stub, "NotImplementedError")])
def test_wrong_octomap_updates_are_caught_with_a_hint(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_octomap_update(wrong)


def test_the_library_update_is_the_checked_one():
    """explicit.octomap_update (torch, in place) agrees with the checker's voxel-by-voxel reference."""
    rng = np.random.default_rng(3)
    model = dict(l_hit=np.log(0.7 / 0.3), l_miss=np.log(0.4 / 0.6), l_min=np.log(0.12 / 0.88), l_max=np.log(0.97 / 0.03))
    for _ in range(20):
        log_odds = rng.uniform(model["l_min"], model["l_max"], 12)
        crossed, hit = np.unique(rng.integers(0, 12, 10)), np.unique(rng.integers(0, 12, 4))
        mine = torch.as_tensor(log_odds.copy())
        octomap_update(mine, torch.as_tensor(crossed), torch.as_tensor(hit), **model)
        assert np.allclose(mine.numpy(), check_octomap_update.reference(log_odds, crossed, hit, **model))


# ---- STE's ROI score of a ray --------------------------------------------------------------------
from stair_lite.exercises.comparison import OCCUPIED, OUTSIDE, UNKNOWN, check_ray_roi_score  # noqa: E402


def roi(state, distance, max_distance, stop=True, per_counted=False, normalise=True, clamp=True, bonus=True):
    total, counted = 0.0, 0
    for s, d in zip(state, distance):
        if s == OUTSIDE:
            continue
        counted += 1
        if s == UNKNOWN:
            extra = 0.5 * (max_distance - d) / max_distance
            total += 0.5 + ((max(0.0, extra) if clamp else extra) if bonus else 0.0)
        if s == OCCUPIED and stop:
            break
    inside = int(np.sum(np.asarray(state) != OUTSIDE))
    if not normalise:
        return total
    return total / max(1, counted if per_counted else inside)


def test_ray_roi_score_accepts_a_loop_over_the_ray():
    assert check_ray_roi_score(roi)


@pytest.mark.parametrize("wrong, hint", [
    (dict(stop=False), "first occupied voxel"),
    (dict(per_counted=True), "not by the number counted"),
    (dict(normalise=False), "normalise"),
    (dict(clamp=False), "never negative"),
    (dict(bonus=False), "near a target scores more"),
])
def test_ray_roi_score_rejects_plausible_mistakes(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_ray_roi_score(lambda *args: roi(*args, **wrong))


def test_ray_roi_score_agrees_with_the_voxel_map():
    """The exercise's rule is the explicit map's: a map with one target voxel scores a view as the sum of its rays'
    exercise scores, recomputed here ray by ray from the map's own march."""
    import torch

    from stair_lite.config import get_preset
    from stair_lite.explicit import ExplicitMap
    from stair_lite.exercises.comparison import _roi_reference
    from stair_lite.geometry import Intrinsics, pixel_rays, view_to_pose
    from stair_lite.scenes import load_scene
    from stair_lite.simulator import Simulator
    from scipy.ndimage import distance_transform_edt

    preset = get_preset("smoke")
    scene = load_scene("scene1")
    voxel_map = ExplicitMap.from_preset(preset)
    voxel_map.integrate(Simulator(scene).render(view_to_pose(1.0, 0.3)))
    view = np.array([[0.6, 2.0]])
    cfg, r = voxel_map.cfg, voxel_map.cfg.resolution
    roi_mask = torch.isin(voxel_map.labels, torch.as_tensor(scene.targets)) & (voxel_map.probability > 0.5)
    assert roi_mask.any()
    distance = distance_transform_edt(~roi_mask.view(r, r, r).numpy()).reshape(-1)
    k = Intrinsics.from_fov().scaled(cfg.candidate_scale)
    origins, dirs = (torch.as_tensor(a, dtype=torch.float32) for a in pixel_rays(k, view_to_pose(*view[0])))
    index, valid = voxel_map._march(origins, dirs, step_voxels=1.0)
    state = np.where(voxel_map.probability[index] > 0.5, OCCUPIED, np.where(voxel_map.observed[index], 0, UNKNOWN))
    state = np.where(valid.numpy(), state, OUTSIDE)
    by_rays = sum(_roi_reference(s, distance[i], cfg.roi_max_distance) for s, i in zip(state, index.numpy()))
    assert voxel_map.roi_scores(view, scene.targets)[0] == pytest.approx(by_rays, rel=1e-4)
