"""Q-based Approximate Value Iteration (Geramifard 2012, Algorithm 7, Eqs. 2.29-2.30)."""

from __future__ import annotations

from typing import Any

from conjure.core.interfaces import Representation
from conjure.core.params import InstanceOf, Interval
from conjure.core.seeding import make_rng
from conjure.planners import _kernels
from conjure.planners.base import Iterations, Plan, Planner

__all__ = ["QAVI"]


class QAVI(Planner):
    """Gradient Bellman updates θ ← θ + αδφ(s, a) over every (s, a) of an exact model.

    Geramifard (2012), Algorithm 7: for every s and a, Q⁺(s, a) = Σ_s' P^a_{ss'}[R + γ
    max_a' Q(s', a')] (line 5), δ = Q⁺ − Q(s, a) (line 6), and the gradient step of Eq. 2.30
    (line 7), with Q(s, a) = φ(s, a)ᵀθ̄ (Eq. 2.11).

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s), copied per action (Eq. 2.11); ``None`` means `Tabular` (Φ = I).
    step_size : float, default 1.0
        α in (0, 1]. With Φ = I and α = 1 each update sets Q(s, a) = Q⁺(s, a).
    tolerance : float, default 1e-8
        Stop when a sweep's max |δ| < tolerance; in (0, inf).
    max_iterations : int, default 10000
        Cap on sweeps ("while time left"), in [1, inf).
    seed : int, default 0
        Seed of θ₀ (line 1, "Random()"), in [0, inf).

    Notes
    -----
    ======  ==============  ====================================
    Symbol  Name            Meaning
    ======  ==============  ====================================
    θ̄       plan.weights    weights, one column per action
    α       step_size       gradient step of Eq. 2.30
    δ       history         per-sweep max |Q⁺ − Q|
    γ       model.discount  discount factor
    ======  ==============  ====================================

    - Choice: θ₀ ~ U(−10⁻⁶, 10⁻⁶) from ``seed`` ("Random()", only breaking argmax ties).
    - Choice: "while time left" is a max-|δ| checkpoint (as Algorithm 2's) plus a sweep cap.
    - Choice: the sweep is in place (Gauss-Seidel): line 5 reads the θ̄ already updated in
      this sweep, as the thesis's loop does. With Φ = I this is value iteration on Q.
    - Choice: Q(terminal, ·) = 0: φ of terminal states is the empty vector.
    - With linear features, keep α ≤ 1/k for k active features, or the steps can diverge.

    Complexity
    ----------
    Θ(nnz(P)·k|A| + |S||A|k) per sweep for k active features (Θ(n|A|²|S|²) dense, Table 2.2).

    Examples
    --------
    >>> from conjure.testing.planner_checks import three_state_model
    >>> plan = QAVI().plan(three_state_model())
    >>> plan.state_values().round(3).tolist(), plan.policy.tolist()
    ([2.989, 3.321, 3.69], [0, 0, 0])
    """

    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "step_size": Interval(float, 0.0, 1.0, closed="right"),
        "tolerance": Interval(float, 0.0, None, closed="neither"),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        step_size: float = 1.0,
        tolerance: float = 1e-8,
        max_iterations: int = 10_000,
        seed: int = 0,
    ):
        self.representation = representation
        self.step_size = step_size
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.seed = seed

    def _plan(self, source: Any) -> Plan:
        model = self._tabular(source)
        rep = _kernels.setup_representation(self.representation, model.domain_spec, self.seed)
        phi = _kernels.state_features(model, rep)
        backups = _kernels.model_backups(model, phi)  # lines 3-5: every (s, a), Q⁺ over P
        weights = _kernels.initial_weights(
            make_rng(self.seed), rep.num_features_, model.num_actions
        )  # line 1
        phi_rows = _kernels.sparse_rows(phi)
        loop = Iterations(self.max_iterations)
        for _ in loop:  # line 2: while time left
            change = _kernels.q_avi_pass(  # lines 3-7
                weights, phi_rows, backups, model.discount, float(self.step_size)
            )
            if loop.record(change) < self.tolerance:
                break
        return _kernels.linear_plan(model.domain_spec, model, rep, weights, loop)
