"""The checker of notebook 08's exercise accepts the headroom instrument's noise ceiling and rejects plausible wrong
ones, each with its hint."""
import numpy as np
import pytest
from scipy import stats

from stair_lite.exercises.league import check_noise_ceiling
from stair_lite.headroom import noise_ceiling


def ceiling_ok(gains):
    c = noise_ceiling(gains)  # the instrument's own computation: the checker agrees with it
    return c["spearman"], c["pick_percentile"]


def _oracle(gains, others, correlate, beaten):
    rhos, picks = [], []
    for s in range(len(gains)):
        oracle = others(gains, s)
        rhos.append(correlate(oracle, gains[s]))
        picks.append(beaten(gains[s], gains[s][np.argmax(oracle)]).mean())
    return np.mean(rhos), np.mean(picks)


def leave_out_mean(gains, s):
    return np.delete(gains, s, axis=0).mean(axis=0)


def spearman(a, b):
    return stats.spearmanr(a, b).statistic


def own_stream(gains):
    return _oracle(gains, lambda g, s: g.mean(axis=0), spearman, np.less)


def pearson(gains):
    return _oracle(gains, leave_out_mean, lambda a, b: np.corrcoef(a, b)[0, 1], np.less)


def ties_beaten(gains):
    return _oracle(gains, leave_out_mean, spearman, np.less_equal)


def others_only(gains):
    rho, pick = ceiling_ok(gains)
    return rho, pick * gains.shape[1] / (gains.shape[1] - 1)


def summed(gains):
    """The oracle as a sum over the other streams (the same ranks as their mean, computed in another order)."""
    return _oracle(gains, lambda g, s: g.sum(axis=0) - g[s], spearman, np.less)


def median(gains):
    return _oracle(gains, lambda g, s: np.median(np.delete(g, s, axis=0), axis=0), spearman, np.less)


def test_the_instruments_ceiling_passes():
    assert check_noise_ceiling(ceiling_ok)


def test_an_oracle_computed_in_another_order_passes():
    """No near-ties in the checker's tables: a sum over the other streams ranks the views as their mean does."""
    assert check_noise_ceiling(summed)


@pytest.mark.parametrize("wrong,hint", [(own_stream, "must not see stream s itself"), (pearson, "Spearman"),
                                        (ties_beaten, "strictly below"), (median, "MEAN gain"),
                                        (others_only, "over ALL the stream's views"),
                                        (lambda gains: (0.5, 0.5), "expected"), (lambda gains: 0.5, "two numbers")])
def test_wrong_ceilings_are_caught_with_a_hint(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_noise_ceiling(wrong)
