"""The checkers of notebook 07's exercises accept correct answers and reject plausible wrong ones by name."""
import numpy as np
import pytest
import torch

from stair_lite.exercises.labels import check_class_entropy, check_soft_exploitation
from stair_lite.utility import class_entropy, target_probability


def entropy_library(sem):
    return class_entropy(torch.as_tensor(sem)).numpy()


def entropy_xlogy(sem):
    from scipy.special import xlogy
    return -xlogy(sem, sem).sum(-1)


def entropy_bits(sem):
    return entropy_xlogy(sem) / np.log(2)


def entropy_nan(sem):
    return -(sem * np.log(sem)).sum(-1)


def entropy_axis0(sem):
    from scipy.special import xlogy
    return -xlogy(sem, sem).sum(0)


def entropy_sign(sem):
    return -entropy_xlogy(sem)


def entropy_normalised(sem):
    return entropy_xlogy(sem) / np.log(sem.shape[-1])


def stub(*args):
    raise NotImplementedError


@pytest.mark.parametrize("answer", [entropy_library, entropy_xlogy])
def test_class_entropy_accepts_right_answers(answer):
    assert check_class_entropy(answer)


@pytest.mark.parametrize("answer, hint", [
    (entropy_bits, "natural log"), (entropy_nan, "0 ln 0 must count as 0"), (entropy_axis0, "LAST axis"),
    (entropy_sign, "minus sign"), (entropy_normalised, "do not divide by ln P"), (stub, "NotImplementedError"),
    (lambda sem: None, "expected")])
def test_class_entropy_rejects_plausible_mistakes_with_their_hint(answer, hint):
    with pytest.raises(AssertionError, match=hint):
        check_class_entropy(answer)


def soft_library(h_ray, sem, targets):
    p = target_probability(torch.as_tensor(sem), targets).numpy()
    return (h_ray * p).sum(axis=(1, 2))


def soft_einsum(h_ray, sem, targets):
    mask = np.zeros(sem.shape[-1])
    mask[list(targets)] = 1
    return np.einsum("vhw,vhwc,c->v", h_ray, sem, mask)


def soft_argmax(h_ray, sem, targets):
    return (h_ray * np.isin(sem.argmax(-1), targets)).sum(axis=(1, 2))


def soft_max(h_ray, sem, targets):
    return (h_ray * sem[..., list(targets)].max(-1)).sum(axis=(1, 2))


def soft_background(h_ray, sem, targets):
    return (h_ray * sem[..., [0, *targets]].sum(-1)).sum(axis=(1, 2))


def soft_any_object(h_ray, sem, targets):
    return (h_ray * (1 - sem[..., 0])).sum(axis=(1, 2))


def soft_total(h_ray, sem, targets):
    return float((h_ray * sem[..., list(targets)].sum(-1)).sum())


def soft_image(h_ray, sem, targets):
    return h_ray * sem[..., list(targets)].sum(-1)


@pytest.mark.parametrize("answer", [soft_library, soft_einsum])
def test_soft_exploitation_accepts_right_answers(answer):
    assert check_soft_exploitation(answer)


@pytest.mark.parametrize("answer, hint", [
    (soft_argmax, "hard mask"), (soft_max, "SUM of the target classes"), (soft_background, "background .class 0. is never"),
    (soft_any_object, "any object"), (soft_total, "one score per view"), (soft_image, "expected"),
    (stub, "NotImplementedError")])
def test_soft_exploitation_rejects_plausible_mistakes_with_their_hint(answer, hint):
    with pytest.raises(AssertionError, match=hint):
        check_soft_exploitation(answer)
