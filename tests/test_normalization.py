"""The actor's observation normalisation against numpy's moments of everything it observed."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th

from sb3_geogp.normalization import CLIP_OBS, EPSILON, ActorObservationNormalizer


def batches(seed: int = 0) -> list[np.ndarray]:
    """Three batches with unequal sizes, far from mean 0 and variance 1."""
    rng = np.random.default_rng(seed)
    scale = np.array([0.05, 3.0, 40.0])
    return [rng.normal(5.0, 1.0, (n, 3)) * scale for n in (7, 64, 1)]


def moments(seen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of ``seen`` pooled with the starting statistics: a weight of 1e-4 at
    mean 0 and variance 1 (SB3's ``RunningMeanStd``)."""
    w, n = 1e-4, len(seen)
    mean = seen.sum(axis=0) / (n + w)
    var = (w * (1.0 + mean**2) + ((seen - mean) ** 2).sum(axis=0)) / (n + w)
    return mean, var


def expected(x: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """The published normalisation, from the moments of ``seen``."""
    mean, var = moments(seen)
    return np.clip((x - mean) / np.sqrt(var + EPSILON), -CLIP_OBS, CLIP_OBS)


def test_publishes_the_moments_of_everything_observed() -> None:
    norm = ActorObservationNormalizer(3)
    for batch in batches():
        norm.observe(batch)
    norm.publish()
    seen = np.concatenate(batches())
    mean, var = moments(seen)
    np.testing.assert_allclose(norm.mean.numpy(), mean, rtol=1e-10)
    np.testing.assert_allclose(norm.var.numpy(), var, rtol=1e-10)
    x = np.concatenate([seen[:5], seen[:1] * 100])  # the last row is clipped
    out = norm(th.as_tensor(x, dtype=th.float32))
    assert out.dtype == th.float32
    np.testing.assert_allclose(out.numpy(), expected(x, seen), rtol=1e-5, atol=1e-5)
    assert (out.abs() == CLIP_OBS).any()


def test_what_it_observes_changes_nothing_until_published() -> None:
    norm = ActorObservationNormalizer(3)
    x = th.as_tensor(batches()[0])
    before = norm(x)
    np.testing.assert_allclose(before.numpy(), np.clip(x.numpy() / np.sqrt(1 + EPSILON), -10, 10))
    norm.observe(batches()[1])
    assert th.equal(norm(x), before)
    norm.publish()
    assert not th.equal(norm(x), before)


@pytest.mark.parametrize(
    ("x", "match"),
    [
        (np.zeros((4, 2)), r"shape \(N, 3\)"),
        (np.zeros(3), r"shape \(N, 3\)"),
        (np.array([[0.0, np.nan, 1.0]]), "NaN or inf"),
        (np.array([[0.0, np.inf, 1.0]]), "NaN or inf"),
    ],
)
def test_bad_inputs_raise_and_leave_the_statistics(x: np.ndarray, match: str) -> None:
    norm = ActorObservationNormalizer(3)
    norm.observe(batches()[1])
    state = {k: v.clone() for k, v in norm.state_dict().items()}
    with pytest.raises(ValueError, match=match):
        norm.observe(x)
    for key, value in norm.state_dict().items():
        assert th.equal(value, state[key]), key


@pytest.mark.parametrize("kwargs", [dict(clip_obs=0.0), dict(epsilon=-1.0)])
def test_bad_settings_raise(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="must be positive"):
        ActorObservationNormalizer(3, **kwargs)


def test_has_no_parameters_and_saves_its_statistics() -> None:
    norm = ActorObservationNormalizer(3)
    norm.observe(batches()[1])
    norm.publish()
    assert not list(norm.parameters())
    copy = ActorObservationNormalizer(3)
    copy.load_state_dict(norm.state_dict())
    x = th.as_tensor(batches()[0])
    assert th.equal(copy(x), norm(x))
