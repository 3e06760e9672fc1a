"""The checker of notebook 06's exercise accepts a correct answer and rejects plausible wrong ones."""
import numpy as np
import pytest
from scipy import stats

from stair_lite.exercises.comparison import check_paired_p_value


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
