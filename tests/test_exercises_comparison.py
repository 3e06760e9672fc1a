"""The checker of notebook 06's exercise accepts a correct answer and rejects plausible wrong ones."""
import numpy as np
import pytest
from scipy import stats

from stair_lite.exercises.comparison import check_welch_p_value


def welch_ok(a, b):
    return stats.ttest_ind(a, b, equal_var=False).pvalue


def welch_student(a, b):
    return stats.ttest_ind(a, b, equal_var=True).pvalue


def welch_one_sided(a, b):
    return stats.ttest_ind(a, b, equal_var=False).pvalue / 2


def welch_ddof0(a, b):
    va, vb = a.var() / len(a), b.var() / len(b)
    t = (a.mean() - b.mean()) / np.sqrt(va + vb)
    dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1))
    return 2 * stats.t.sf(abs(t), dof)


def welch_normal(a, b):
    t = (a.mean() - b.mean()) / np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    return 2 * stats.norm.sf(abs(t))


def stub(a, b):
    raise NotImplementedError


def test_a_correct_welch_test_passes():
    assert check_welch_p_value(welch_ok)


@pytest.mark.parametrize("wrong,hint", [(welch_student, "pooled"), (welch_one_sided, "two-sided"),
                                        (welch_ddof0, "ddof=1"), (welch_normal, "normal distribution"),
                                        (stub, "NotImplementedError"), (lambda a, b: 0.5, "expected")])
def test_wrong_welch_tests_are_caught_with_a_hint(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_welch_p_value(wrong)
