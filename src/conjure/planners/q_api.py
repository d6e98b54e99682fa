"""Q-based Approximate Policy Iteration (Geramifard 2012, Algorithm 4, Eqs. 2.18-2.20)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.linalg import feature_matrix
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners._api import ModelAPI
from conjure.planners.base import Iterations, Plan

__all__ = ["QAPI"]


class QAPI(ModelAPI):
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

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        num_states, num_actions = model.num_states, model.num_actions
        rep = _kernels.setup_representation(self.representation, model.domain_spec, self.seed)
        phi = sp.csr_matrix(
            sp.diags((~model.is_terminal).astype(np.float64)) @ feature_matrix(rep, model.states)
        )
        phi_bar = _kernels.block_features(phi, num_actions)  # Φ̄, (|A||S| × n|A|)
        r_bar = model.rewards_by_action.reshape(-1)  # R̄, action-major
        policy = _kernels.initial_policy(model, make_rng(self.seed))
        loop = Iterations(self.max_iterations)
        for _ in loop:
            d, probs = _kernels.policy_weighting(model, policy, float(self.epsilon), self.weighting)
            d_bar = (probs * d[:, None]).T.reshape(-1)  # D̄(s, a), action-major
            phi_pi = _kernels.action_features(phi, policy, num_actions)  # φ(s', π(s'))
            p_phi = model.stacked_transitions @ phi_pi  # P̄Φ̄
            weights = self._solve(phi_bar, p_phi, r_bar, d_bar, model.discount)  # Eq. 2.19/2.20
            q = np.asarray(phi_bar @ weights).reshape(num_actions, num_states).T  # Q = Φ̄θ̄
            policy, num_changed = _kernels.improve_policy(q, policy)  # π⁺ = argmax_a Q
            if loop.record(num_changed) == 0:
                break
        return loop.plan(
            model.domain_spec,
            model=model,
            policy=policy,
            q_values=q.copy(),
            representation=rep,
            weights=_kernels.weights_by_action(weights, num_actions).copy(),
        )
