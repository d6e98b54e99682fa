"""Sampled Q-API-1 and -2 (Geramifard 2012, Algorithms 5 and 6, Eqs. 2.21-2.28)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import Representation
from conjure.core.params import NEXT_SAMPLES, SAMPLES, InstanceOf, Interval, Options
from conjure.models.generative import ModelSampler
from conjure.planners import _kernels
from conjure.planners._sampling import Sampling, solve_q_weights
from conjure.planners.base import Iterations, Plan, Planner

__all__ = ["SampledQAPI1", "SampledQAPI2"]

_CONSTRAINTS = {
    "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
    "evaluation": Options(("lstd", "brm")),
    "num_samples": SAMPLES,
    "epsilon": Interval(float, 0.0, 1.0),
    "regularization": Interval(float, 0.0, None),
    "max_iterations": Interval(int, 1, None),
    "seed": Interval(int, 0, None),
}


class SampledQAPI1(Planner):
    """Q-API on L₁ sampled pairs with exact expectations φ̄ = Σ P φ(s', π(s')) (Eq. 2.21).

    Geramifard (2012), Algorithm 5: each iteration follows π^ε for L₁ steps (line 5), builds
    Φ̃ (Eq. 2.22), P̃Φ̄ (Eq. 2.21) and R̃ from the exact model, solves Ã θ̄ = b̃ of Eqs.
    2.23-2.24 (LSTD) or 2.25-2.26 (BRM) (lines 6-7) and improves π(s) = argmax_a Q(s, a) for
    every state (lines 8-10), until π stops changing.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular`.
    evaluation : {"lstd", "brm"}, default "lstd"
        Eqs. 2.23-2.24 or Eqs. 2.25-2.26.
    num_samples : int, default 300
        L₁, samples per iteration, in [1, 10^7].
    epsilon : float, default 0.1
        ε of the sampling policy π^ε, in [0, 1] (ε > 0 keeps the samples ergodic, Fig. 2-5).
    regularization : float, default 1e-8
        λ ≥ 0 added to Ã's diagonal (the inverse does not exist for unvisited pairs).
    max_iterations : int, default 50
        Cap on policy improvements, in [1, inf).
    seed : int, default 0
        Seed of the random initial policy (line 2) and of the sampling, in [0, inf).

    Notes
    -----
    ======  ================  ====================================
    Symbol  Name              Meaning
    ======  ================  ====================================
    L₁      num_samples       pairs ⟨s_i, a_i⟩ per iteration
    ε       epsilon           exploration of π^ε (line 5)
    λ       regularization    ridge term of the solve
    ======  ================  ====================================

    - Choice: the samples form one trajectory of π^ε over the model's states from the start
      distribution, restarting at termination and after ``spec.max_episode_steps`` steps
      (one endless episode of a non-terminating chain would cover one region only).
    - Choice: θ̄ of line 1 is never read before line 7 sets it, so it is not drawn.
    - Choice: improvement ties keep the previous action, so the loop cannot cycle on ties.
    - Choice: Q(terminal, ·) = 0 (terminal rows of Φ are empty).

    Complexity
    ----------
    Θ(k L₁ nnz(P_s) + |S||A|k + n³|A|³) per iteration (Θ(nL₁|S| + |S||A| + n³|A|³), Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = SampledQAPI1().plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    parameter_constraints = _CONSTRAINTS

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        evaluation: str = "lstd",
        num_samples: int = 300,
        epsilon: float = 0.1,
        regularization: float = 1e-8,
        max_iterations: int = 50,
        seed: int = 0,
    ):
        self.representation = representation
        self.evaluation = evaluation
        self.num_samples = num_samples
        self.epsilon = epsilon
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.seed = seed

    def _sample_pairs(
        self, sampler: ModelSampler, policy: np.ndarray, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Line 5: L₁ state indices and actions following π^ε (restarting episodes)."""
        model = sampler.model
        num_actions, epsilon = model.num_actions, float(self.epsilon)
        states = np.empty(self.num_samples, dtype=np.int64)
        actions = np.empty(self.num_samples, dtype=np.int64)
        cap = model.domain_spec.max_episode_steps
        state, steps = sampler.sample_start_index(rng), 0
        for i in range(self.num_samples):
            action = int(rng.integers(num_actions)) if rng.random() < epsilon else policy[state]
            states[i], actions[i] = state, action
            state, steps = sampler.sample_index(state, action, rng), steps + 1
            if model.is_terminal[state] or steps >= cap:
                state, steps = sampler.sample_start_index(rng), 0
        return states, actions

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        num_states, num_actions = model.num_states, model.num_actions
        sampling = Sampling(ModelSampler(model), model, self.representation, self.seed)
        sampler, rng, rep = sampling.sampler, sampling.rng, sampling.representation
        phi = _kernels.state_features(model, rep)
        stacked = model.stacked_transitions
        policy = _kernels.initial_policy(model, rng)  # line 2
        weights = np.zeros((phi.shape[1], num_actions))
        q = np.zeros((num_states, num_actions))
        loop = Iterations(self.max_iterations)
        for _ in loop:  # line 4: while changed
            states, actions = self._sample_pairs(sampler, policy, rng)  # line 5
            phi_bar = _kernels.action_features(phi[states], actions, num_actions)  # Eq. 2.22
            phi_pi = _kernels.action_features(phi, policy, num_actions)  # φ(s', π(s'))
            p_phi = sp.csr_matrix(stacked[actions * num_states + states] @ phi_pi)  # Eq. 2.21
            rewards = model.rewards[states, actions]  # ρ(s_i, a_i)
            weights = solve_q_weights(  # lines 6-7
                self.evaluation,
                phi_bar,
                p_phi,
                rewards,
                model.discount,
                self.regularization,
                num_actions,
            )
            q = _kernels.q_from_weights(phi, weights)  # line 8: Q = Φ̄θ̄
            policy, num_changed = _kernels.improve_policy(q, policy)  # lines 9-10
            if loop.record(num_changed) == 0:  # line 11: changed ← (π⁺ ≠ π)
                break
        return loop.plan(
            model.domain_spec,
            model=model,
            policy=policy,
            q_values=q,
            representation=rep,
            weights=weights,
        )


class SampledQAPI2(Planner):
    """Q-API on samples only: φ̄ from L₂ draws (Eq. 2.28), π computed on demand (Eq. 2.2).

    Geramifard (2012), Algorithm 6: each iteration follows π^ε for L₁ steps (line 4), draws
    L₂ successors s'_j ~ P(s_i, a_i) of each sample and averages φ(s'_j, π(s'_j)) with π
    greedy in the current θ̄ (Eq. 2.28, line 5), solves Eqs. 2.23-2.24 or 2.25-2.26 (lines
    6-7), and stops when the policy on a fixed set of states stops changing. Needs only a
    generative model: a `TabularModel`, or a domain with ``set_state`` or ``model()``.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular`.
    evaluation : {"lstd", "brm"}, default "lstd"
        Eqs. 2.23-2.24 or Eqs. 2.25-2.26.
    num_samples : int, default 300
        L₁, samples per iteration, in [1, 10^7].
    num_next_samples : int, default 1
        L₂, successor draws per sample, in [1, 10^4].
    epsilon : float, default 0.1
        ε of the sampling policy π^ε, in [0, 1].
    regularization : float, default 1e-8
        λ ≥ 0 added to Ã's diagonal.
    max_iterations : int, default 50
        Cap on iterations, in [1, inf).
    seed : int, default 0
        Seed of θ₀ and of all sampling, in [0, inf).

    Notes
    -----
    ======  ================  ====================================
    Symbol  Name              Meaning
    ======  ================  ====================================
    L₁      num_samples       pairs ⟨s_i, a_i⟩ per iteration
    L₂      num_next_samples  draws s' ~ P(s_i, a_i) per pair
    ε       epsilon           exploration of π^ε
    ======  ================  ====================================

    - Choice: "the policy for a fixed set of states remains unchanged after one iteration":
      the fixed set is the states of the first iteration's samples.
    - Choice: with BRM the same L₂ draws serve both factors of Ã (Eq. 2.25); an unbiased
      estimate would need independent draws (Eq. 2.43), which LSPI-BRM implements.
    - Choice: samples form one trajectory of π^ε from the start distribution, continuing from
      the first draw and restarting at termination or after the episode cap; θ₀ ~ U(−10⁻⁶,
      10⁻⁶) ("Random()").
    - Choice: with a `TabularModel` the reward of a draw is R(s, a); a terminal successor
      contributes φ = 0.

    Complexity
    ----------
    Θ(k L₁ |A| + k L₁ L₂ |A| + k² L₁ + n³|A|³) per iteration (Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = SampledQAPI2().plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    is_sampled = True
    parameter_constraints = {**_CONSTRAINTS, "num_next_samples": NEXT_SAMPLES}

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        evaluation: str = "lstd",
        num_samples: int = 300,
        num_next_samples: int = 1,
        epsilon: float = 0.1,
        regularization: float = 1e-8,
        max_iterations: int = 50,
        seed: int = 0,
    ):
        self.representation = representation
        self.evaluation = evaluation
        self.num_samples = num_samples
        self.num_next_samples = num_next_samples
        self.epsilon = epsilon
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        sampling = Sampling(*self._generative(source), self.representation, self.seed)
        num_actions = sampling.num_actions
        fixed_phi = None  # φ of the fixed set of states (the first batch's)

        def evaluate(data: dict[str, Any], weights: np.ndarray) -> tuple[np.ndarray, float]:
            nonlocal fixed_phi
            if fixed_phi is None:
                fixed_phi = data["phi"]
            before = _kernels.q_from_weights(fixed_phi, weights).argmax(axis=1)
            phi_bar = _kernels.action_features(data["phi"], data["actions"], num_actions)
            p_phi = _kernels.greedy_next_features(  # Eq. 2.28 with π on demand
                data["phi_next"], weights, data["num_next"]
            )
            fitted = solve_q_weights(  # lines 6-7
                self.evaluation,
                phi_bar,
                p_phi,
                data["rewards"].mean(axis=1),
                sampling.spec.discount,
                self.regularization,
                num_actions,
            )
            after = _kernels.q_from_weights(fixed_phi, fitted).argmax(axis=1)
            return fitted, np.count_nonzero(after != before)

        return sampling.iterate(  # lines 1-5
            evaluate,
            epsilon=self.epsilon,
            num_samples=self.num_samples,
            num_next=self.num_next_samples,
            tolerance=1,  # stop when no state of the fixed set changes action
            max_iterations=self.max_iterations,
        )
