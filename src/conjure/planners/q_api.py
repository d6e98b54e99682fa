"""Q-based Approximate Policy Iteration (Geramifard 2012, Algorithm 4, Eqs. 2.18-2.20)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import Representation
from conjure.core.linalg import solve_regularized
from conjure.core.params import InstanceOf, Interval, Options
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners.base import Plan, Planner

__all__ = ["QAPI"]


class QAPI(Planner):
    """Approximate Q^π ≈ Φ̄θ̄ by BRM (Eq. 2.19) or LSTD (Eq. 2.20); π⁺(s) = argmax_a Q(s, a).

    Geramifard (2012), Algorithm 4.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular`.
    evaluation : {"lstd", "brm"}, default "lstd"
        Eq. 2.20 or Eq. 2.19.
    epsilon : float, default 0.1
        The ε of π^ε whose state-action distribution forms D̄, in [0, 1].
    weighting : {"uniform", "steady_state"}, default "uniform"
        How states are weighted in D̄.
    regularization : float, default 1e-10
        λ ≥ 0 added to Ā's diagonal.
    max_iterations : int, default 100
        Cap on policy improvements, in [1, inf).
    seed : int, default 0
        Seed of the random initial policy.

    Notes
    -----
    - Choice: D̄(s, a) = d(s)·π^ε(a|s), with d the steady state of π^ε (restarting episodes).
      The thesis's D̄ from P̄ weights only a = π(s), which leaves Ā singular for every other
      action (the ergodicity problem of Figure 2-5); ε > 0 keeps every pair weighted.
    - Choice: d defaults to uniform over non-terminal states; ``weighting="steady_state"``
      gives the thesis's D̄ (see `VAPI` for why it is not the default).
    - Choice: rows and P̄Φ̄ are action-major, (a, s) ↦ a·|S| + s; Q(terminal, ·) = 0.

    Complexity
    ----------
    Θ(nnz(P)·k·|A| + n³|A|³) per iteration (Θ(n|A||S|² + n³|A|³) dense, Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = QAPI(regularization=0.0).plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "evaluation": Options(("lstd", "brm")),
        "epsilon": Interval(float, 0.0, 1.0),
        "weighting": Options(("steady_state", "uniform")),
        "regularization": Interval(float, 0.0, None),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        evaluation: str = "lstd",
        epsilon: float = 0.1,
        weighting: str = "uniform",
        regularization: float = 1e-10,
        max_iterations: int = 100,
        seed: int = 0,
    ):
        self.representation = representation
        self.evaluation = evaluation
        self.epsilon = epsilon
        self.weighting = weighting
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        num_states, num_actions = model.num_states, model.num_actions
        rep = _kernels.setup_representation(self.representation, model.domain_spec, self.seed)
        phi = sp.csr_matrix(
            sp.diags((~model.is_terminal).astype(np.float64))
            @ _kernels.encode_states(rep, model.states)
        )
        n = phi.shape[1]
        phi_bar = _kernels.block_features(phi, num_actions)  # Φ̄, (|A||S| × n|A|)
        r_bar = model.rewards_by_action.reshape(-1)  # R̄, action-major
        policy = make_rng(self.seed).integers(num_actions, size=num_states)
        weights = np.zeros(n * num_actions)
        history: list[float] = []
        iterations = 0
        for iteration in range(1, self.max_iterations + 1):
            iterations = iteration
            d, probs = _kernels.policy_weighting(model, policy, float(self.epsilon), self.weighting)
            d_bar = (probs * d[:, None]).T.reshape(-1)  # D̄(s, a), action-major
            phi_pi = _kernels.action_features(phi, policy, num_actions)  # φ(s', π(s'))
            p_phi = model.stacked_transitions @ phi_pi  # P̄Φ̄
            residual = phi_bar - model.discount * p_phi
            left = sp.csr_matrix((residual if self.evaluation == "brm" else phi_bar).T)
            left = left @ sp.diags(d_bar)
            weights = solve_regularized(left @ residual, left @ r_bar, self.regularization)
            q = np.asarray(phi_bar @ weights).reshape(num_actions, num_states)  # Q = Φ̄θ̄
            improved = _kernels.greedy_policy(q, policy)
            num_changed = int(np.count_nonzero(improved != policy))
            history.append(float(num_changed))
            policy = improved
            if num_changed == 0:
                break
        return Plan(
            planner="",
            spec=model.domain_spec,
            iterations=iterations,
            wall_time_s=0.0,
            model=model,
            policy=policy,
            q_values=q.T.copy(),
            representation=rep,
            weights=weights.reshape(num_actions, n).T.copy(),
            history=history,
        )
