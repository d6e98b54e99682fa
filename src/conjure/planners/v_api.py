"""V-based Approximate Policy Iteration with BRM or LSTD evaluation (Geramifard 2012, Alg. 3)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.linalg import feature_matrix
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners._api import ModelAPI
from conjure.planners.base import Iterations, Plan

__all__ = ["VAPI"]


class VAPI(ModelAPI):
    """Approximate V^π ≈ Φθ by BRM (Eq. 2.15) or LSTD (Eq. 2.17), then improve by Eq. 2.9.

    Geramifard (2012), Algorithm 3 (Section 2.5).

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s); ``None`` means `Tabular` (Φ = I on discrete states).
    evaluation : {"lstd", "brm"}, default "lstd"
        Eq. 2.17 (A = ΦᵀD(Φ − γPΦ)) or Eq. 2.15 (A = (Φ − γPΦ)ᵀD(Φ − γPΦ)).
    epsilon : float, default 0.1
        D is the steady state of π^ε (Eq. 2.27), in [0, 1]; ε > 0 keeps every state weighted.
    weighting : {"uniform", "steady_state"}, default "uniform"
        D: the steady-state distribution of π^ε (Eq. 2.14) or uniform over states.
    regularization : float, default 1e-10
        λ ≥ 0 added to A's diagonal ("use regularization if the inverse does not exist").
    max_iterations : int, default 100
        Cap on policy improvements, in [1, inf).
    seed : int, default 0
        Seed of the random initial policy (line 1) and the representation.

    Notes
    -----
    - Choice: in episodic models (terminal states) the steady state is that of the chain in
      which termination restarts from the start distribution; terminal states get weight 0 and
      V(terminal) = 0.
    - Choice: D is the steady state of π^ε, not of π: with a deterministic π, states π never
      reaches get weight 0, their values are regularised to 0 and improvement can stall (the
      ergodicity problem of Figure 2-5); ``epsilon=0`` gives the thesis's literal D.
    - Choice: D defaults to uniform over non-terminal states; ``weighting="steady_state"``
      gives the thesis's D, which can weight rarely visited states almost zero (9⁻¹⁹ at the
      far end of the 20-state chain walk), so that regularisation wipes out their values.
    - Choice: every matrix is sparse (Φ, P^π, D); A is n × n.

    Complexity
    ----------
    Θ(nnz(P)·k + n³) per iteration with k active features (Θ(n|S|² + |A||S|²) dense, Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = VAPI(regularization=0.0).plan(three_state_model())
    >>> plan.values.round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        rep = _kernels.setup_representation(self.representation, model.domain_spec, self.seed)
        phi = feature_matrix(rep, model.states)
        live = sp.diags((~model.is_terminal).astype(np.float64))
        phi_live = sp.csr_matrix(live @ phi)  # V(terminal) = 0
        policy = _kernels.initial_policy(model, make_rng(self.seed))
        loop = Iterations(self.max_iterations)
        for _ in loop:
            d, _ = _kernels.policy_weighting(model, policy, float(self.epsilon), self.weighting)
            p_phi = model.policy_matrix(policy) @ phi_live
            r_pi = model.policy_rewards(policy)
            weights = self._solve(phi_live, p_phi, r_pi, d, model.discount)  # line 5
            values = np.asarray(phi_live @ weights).reshape(-1)  # line 6: V = Φθ
            q = model.q_values(values)
            policy, num_changed = _kernels.improve_policy(q, policy)  # lines 7-8
            if loop.record(num_changed) == 0:
                break
        return loop.plan(
            model.domain_spec,
            model=model,
            policy=policy,
            values=values,
            q_values=q,
            representation=rep,
            weights=weights,
        )
