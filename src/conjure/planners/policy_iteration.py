"""Policy Iteration with sparse exact policy evaluation (Geramifard 2012, Algorithm 1)."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.params import Interval, Options
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners.base import Iterations, Plan, Planner

__all__ = ["PolicyIteration"]


class PolicyIteration(Planner):
    """Alternate V^π = (I − γP^π)⁻¹R^π (Eq. 2.8) and greedy improvement (Eq. 2.9) until π is stable.

    Geramifard (2012), Algorithm 1.

    Parameters
    ----------
    evaluation : {"auto", "direct", "iterative"}, default "auto"
        Line 4's solve: sparse LU (``direct``), BiCGSTAB warm-started from the previous V
        (``iterative``), or direct up to 200,000 states (``auto``).
    max_iterations : int, default 1000
        Cap on policy improvements, in [1, inf).
    seed : int, default 0
        Seed of line 1's random initial policy, in [0, inf).

    Notes
    -----
    - Choice: the linear system is sparse and restricted to non-terminal states (V(terminal) = 0);
      no |S| × |S| dense matrix is formed.
    - Choice: if (I − γP^π) is singular (an improper policy under γ = 1), V^π is estimated by
      10,000 sweeps of the fixed policy instead (modified policy iteration for that step).
    - Choice: improvement keeps the current action on ties (within 1e-12), so the loop ends.

    Complexity
    ----------
    Per iteration one sparse factorisation (Θ(|S|³) dense, Table 2.2) plus Θ(nnz(P)) for
    lines 5-6.

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = PolicyIteration().plan(three_state_model())
    >>> plan.values.round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    parameter_constraints = {
        "evaluation": Options(("auto", "direct", "iterative")),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(self, *, evaluation: str = "auto", max_iterations: int = 1000, seed: int = 0):
        self.evaluation = evaluation
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        rng = make_rng(self.seed)
        policy = _kernels.initial_policy(model, rng)  # line 1
        values = np.zeros(model.num_states)
        loop = Iterations(self.max_iterations)
        for _ in loop:
            values = _kernels.evaluate_policy(  # line 4
                model, policy, method=self.evaluation, initial=values
            )
            q = model.q_values(values)
            policy, num_changed = _kernels.improve_policy(q, policy)  # lines 5-6
            if loop.record(num_changed) == 0:  # line 7
                break
        return loop.plan(
            model.domain_spec,
            model=model,
            policy=policy,
            values=values,
            q_values=q,
        )
