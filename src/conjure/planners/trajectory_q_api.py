"""Trajectory Sampling Q-API (Geramifard 2012, Algorithm 13, Eqs. 2.34-2.36)."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.interfaces import Representation
from conjure.core.params import SAMPLES, InstanceOf, Interval
from conjure.planners import _kernels
from conjure.planners._sampling import Sampling, solve_q_weights, weight_change
from conjure.planners.base import Plan, Planner

__all__ = ["TrajectoryQAPI"]


class TrajectoryQAPI(Planner):
    """Q-API from fresh trajectories ⟨s_i, a_i, r_i, s'_i, a'_i⟩ of π^ε, one LSTD-Q per batch.

    Geramifard (2012), Algorithm 13: each iteration follows π^ε (ε-greedy in the current Q,
    Eq. 2.27) for L₁ steps (line 3), forms Φ̃, P̃Φ̃ (rows φ(s'_i, a'_i)) and R̃ of Eq. 2.34
    and Ã, b̃ of Eqs. 2.35-2.36 (line 4), and solves θ̄ = Ã⁻¹b̃ (line 5). Samples are thrown
    away after each iteration (LSPI, Algorithm 14, reuses them). Needs only a generative model.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular`.
    num_samples : int, default 1000
        L₁, samples per iteration, in [1, 10^7].
    epsilon : float, default 0.1
        ε of the sampling policy π^ε, in [0, 1].
    regularization : float, default 1e-8
        λ ≥ 0 added to Ã's diagonal.
    tolerance : float, default 1e-6
        Stop when max |θ̄_{k+1} − θ̄_k| < tolerance; in (0, inf).
    max_iterations : int, default 20
        Cap on iterations ("while time left"), in [1, inf).
    seed : int, default 0
        Seed of θ₀ and of all sampling, in [0, inf).

    Notes
    -----
    ======  ================  ====================================
    Symbol  Name              Meaning
    ======  ================  ====================================
    L₁      num_samples       samples per iteration
    ε       epsilon           exploration of π^ε (line 3)
    λ       regularization    ridge term of the solve
    ======  ================  ====================================

    - Choice: a'_i is the action π^ε took next on the trajectory (a_{i+1}; where the
      trajectory restarts, and for the last sample, a' is drawn from π^ε at s'_i), so each
      batch evaluates π^ε on-policy, as Eq. 2.34 reads: the returned Q is that of the
      ε-greedy policy, within O(ε) of Q*. ``epsilon=0`` gives
      the greedy policy's Q but, as Figure 2-5 warns, only on the pairs it visits.
    - Choice: the trajectory restarts at termination and after ``spec.max_episode_steps``
      steps; θ₀ ~ U(−10⁻⁶, 10⁻⁶) ("Random()"); a terminal successor contributes φ = 0.

    Complexity
    ----------
    Θ(k L₁ |A| + k² L₁ + n³|A|³) per iteration (Table 2.3).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = TrajectoryQAPI().plan(three_state_model())
    >>> plan.policy.tolist(), plan.iterations
    ([0, 0, 0], 20)
    """

    is_sampled = True
    expected_check_failures = {
        "check_planner_matches_closed_form": "Alg 13 evaluates π^ε on-policy (a'_i of Eq. "
        "2.34), so its V is V^{π^ε}, not V*; tests compare it with the exact Q^{π^ε}",
    }
    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "num_samples": SAMPLES,
        "epsilon": Interval(float, 0.0, 1.0),
        "regularization": Interval(float, 0.0, None),
        "tolerance": Interval(float, 0.0, None, closed="neither"),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        num_samples: int = 1000,
        epsilon: float = 0.1,
        regularization: float = 1e-8,
        tolerance: float = 1e-6,
        max_iterations: int = 20,
        seed: int = 0,
    ):
        self.representation = representation
        self.num_samples = num_samples
        self.epsilon = epsilon
        self.regularization = regularization
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.seed = seed

    @staticmethod
    def _next_actions(batch: dict[str, Any], choose: Any, rng: np.random.Generator) -> np.ndarray:
        """a'_i = a_{i+1} where the trajectory continues from s'_i, else a fresh π^ε(s'_i)."""
        states, actions, nexts = batch["states"], batch["actions"], batch["next_states"][:, 0]
        continues = np.zeros(actions.shape[0], dtype=bool)
        continues[:-1] = np.all(states[1:] == nexts[:-1], axis=1)
        next_actions = np.empty_like(actions)
        next_actions[:-1] = actions[1:]
        for i in np.flatnonzero(~continues):  # restarts (and the last sample)
            next_actions[i] = choose(nexts[i], rng)
        return next_actions

    def _plan(self, source: Any) -> Plan:
        sampling = Sampling(*self._generative(source), self.representation, self.seed)
        num_actions = sampling.num_actions

        def evaluate(data: dict[str, Any], weights: np.ndarray) -> tuple[np.ndarray, float]:
            choose = sampling.policy(weights, self.epsilon)  # the π^ε that drew the batch
            next_actions = self._next_actions(data, choose, sampling.rng)
            phi_bar = _kernels.action_features(data["phi"], data["actions"], num_actions)
            p_phi = _kernels.action_features(data["phi_next"], next_actions, num_actions)
            fitted = solve_q_weights(  # lines 4-5: Eqs. 2.34-2.36, θ̄ = Ã⁻¹b̃
                "lstd",
                phi_bar,
                p_phi,
                data["rewards"][:, 0],
                sampling.spec.discount,
                self.regularization,
                num_actions,
            )
            return fitted, weight_change(fitted, weights)

        return sampling.iterate(  # lines 1-3
            evaluate,
            epsilon=self.epsilon,
            num_samples=self.num_samples,
            tolerance=self.tolerance,
            max_iterations=self.max_iterations,
        )
