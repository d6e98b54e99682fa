"""The compiled loop's action choice is the policy's own: same draw, same action."""

import numpy as np
import pytest

from conjure.policies import EpsilonGreedy, Gibbs
from conjure.policies.compiled_policy import select_action


@pytest.mark.parametrize(
    "policy", [EpsilonGreedy(epsilon=0.3), Gibbs(temperature=0.5), Gibbs(temperature=0.0)]
)
def test_select_action_draws_as_the_policy(policy):
    values = np.array([0.1, 0.5, 0.5, -1.0])
    legal = np.array([0, 1, 2, 3])
    python_rng, kernel_rng = np.random.default_rng(4), np.random.default_rng(4)
    form = policy.compiled_form()
    for _ in range(200):
        assert select_action(form, values, legal, kernel_rng) == policy.select(
            values, python_rng, legal
        )
