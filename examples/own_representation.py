"""Your own representation φ(s): one method to write, then every learner and planner uses it.

A representation maps a state to features (Geramifard 2012, Section 2.4). conjure's one
feature contract is ``encode(state) -> SparseFeatures(indices, values)``: the sorted indices
of the non-zero features with their values. A binary representation writes only
``active_features(state)`` (the sorted int64 indices of its active features) and inherits
``encode`` with values of 1; a real-valued one (like Gaussian RBF) writes ``encode``.

This script defines `HalfSpaces` (for each state dimension, one feature for "below the
middle" and one for "at or above it"), checks it with the shipped common checks, registers it
so configs can name it, and learns the pendulum with SARSA on it, once from Python objects
and once from a config.

Run with:  python examples/own_representation.py
"""

from __future__ import annotations

import numpy as np

from conjure.agents import SARSA
from conjure.core.interfaces import DomainSpec, Representation
from conjure.core.seeding import as_seed_sequence
from conjure.domains import InvertedPendulum
from conjure.experiments import registry, run, run_config
from conjure.testing import check_component


class HalfSpaces(Representation):
    """Two binary features per dimension: s_d < middle_d and s_d >= middle_d (2d features)."""

    def __init__(self) -> None:
        pass  # no parameters; components store their parameters and nothing else

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> HalfSpaces:
        """Remember the middle of each dimension's range."""
        as_seed_sequence(seed)  # no randomness here, but the seed is checked like everywhere
        self.spec_ = spec
        self.middle_ = (spec.low + spec.high) / 2.0
        self.num_features_ = 2 * spec.num_dims
        self.is_set_up_ = True
        return self

    def active_features(self, state: np.ndarray) -> np.ndarray:
        """Feature 2d for the lower half of dimension d, 2d + 1 for the upper half (sorted)."""
        state = self.check_state(state)
        upper = (state >= self.middle_).astype(np.int64)
        return 2 * np.arange(state.shape[0], dtype=np.int64) + upper


def main(budget_steps: int = 5_000) -> tuple[list[float], list[float]]:
    """Learn with `HalfSpaces` from objects and from a config; return both curves of steps
    balanced by the greedy policy (``episode_length``, one entry per policy check)."""
    check_component(HalfSpaces())  # the checks every shipped representation passes
    registry.REPRESENTATIONS["HalfSpaces"] = HalfSpaces  # configs may now name it
    phi = HalfSpaces().setup(InvertedPendulum().domain_spec, seed=0).encode(np.zeros(2))
    print(f"phi(0, 0): indices {phi.indices.tolist()}, values {phi.values.tolist()}")

    agent = SARSA(representation=HalfSpaces(), step_size=0.1)
    from_objects = run(domain=InvertedPendulum(), agent=agent, budget_steps=budget_steps, seed=0)
    config = {
        "name": "half_spaces",
        "domain": {"kind": "InvertedPendulum"},
        "agents": {
            "sarsa": {
                "kind": "SARSA",
                "params": {"representation": {"kind": "HalfSpaces"}, "step_size": 0.1},
            }
        },
        "budget_steps": budget_steps,
        "seeds": [0],
    }
    from_config = run_config(config, agent_name="sarsa", seed=0)
    curves = (
        from_objects.curve["episode_length"].tolist(),
        from_config.curve["episode_length"].tolist(),
    )
    print(f"steps balanced by the greedy policy at each check: {curves[0]} (objects)")
    print(f"the same from the config: {curves[1]}")
    return curves


if __name__ == "__main__":
    main()
