"""The tempered sequential Monte Carlo sampler (mirl.learning.smc) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import betaln, expit

from mirl.learning.smc import tempered_smc


def _uniform_prior_in_logit_space():
    """p uniform on (0, 1), as a density of x = logit p (Jacobian p (1 − p))."""

    def sample(rng, n):
        p = rng.random((n, 1))
        return np.log(p) - np.log1p(-p)

    def log_prior(x):
        return (-np.logaddexp(0, -x) - np.logaddexp(0, x))[:, 0]

    return sample, log_prior


@pytest.mark.parametrize(("k", "n"), [(3, 10), (70, 100), (600, 900), (900, 900)])
def test_evidence_and_posterior_of_a_binomial(k, n):
    """Successes k of n under p ~ U(0, 1): the evidence is B(k + 1, n − k + 1) and the
    posterior Beta(k + 1, n − k + 1)."""
    sample, log_prior = _uniform_prior_in_logit_space()

    def log_lik(x):
        log_p, log_q = -np.logaddexp(0, -x[:, 0]), -np.logaddexp(0, x[:, 0])
        return k * log_p + (n - k) * log_q

    draws = tempered_smc(sample, log_prior, log_lik, n_draws=2000, random_state=1)
    assert draws.log_evidence == pytest.approx(betaln(k + 1, n - k + 1), abs=0.1)
    mean = float(draws.weights @ expit(draws.x[:, 0]))
    assert mean == pytest.approx((k + 1) / (n + 2), abs=0.01)


def test_both_modes_of_a_symmetric_posterior_are_kept():
    """Two parts whose product alone the data fix (a ridge), one of them damaged: the
    posterior is symmetric, and the draws put about half their weight on each side."""
    sample, log_prior = _uniform_prior_in_logit_space()

    def sample2(rng, n):
        return np.hstack([sample(rng, n), sample(rng, n)])

    def log_prior2(x):
        return log_prior(x[:, :1]) + log_prior(x[:, 1:])

    def log_lik(x):
        log_p = -np.logaddexp(0, -x).sum(axis=1)
        return 300 * log_p + 200 * np.log(-np.expm1(np.minimum(log_p, -1e-12)))

    shares = []
    for seed in range(4):
        d = tempered_smc(sample2, log_prior2, log_lik, n_draws=2000, random_state=seed)
        p = expit(d.x)
        shares.append(float(d.weights @ (p[:, 0] < p[:, 1])))
    assert np.mean(shares) == pytest.approx(0.5, abs=0.1)
    assert min(shares) > 0.2
