"""Cost constraints of the linear TD learners: a cost critic and a Lagrange multiplier.

A constrained MDP (Altman 1999) asks for the best return subject to a cost limit d on the
expected cost per episode, J_C(π) = E[Σ_t c_t] ≤ d, with c_t the domain's ``info["cost"]``
(`conjure.core.Transition.cost`). Its Lagrangian relaxation maximises J_R − λ(J_C − d) over
π while λ ≥ 0 rises when the limit is exceeded and falls toward 0 when it is met. A learner
given ``constraint=`` (`SARSA`, `QLearning`, `ActorCritic`) then, on both paths, through the
kernels of `conjure.agents.compiled_agent`:

- learns a cost critic θ_C on its own features, by its own TD rule on c_t at its step size
  (SARSA and Actor-Critic: c + γ Q_C(s', a'), V_C(s') for the state-value critic;
  Q-Learning: c + γ Q_C(s', a*) with a* the legal action maximising Q − λQ_C, which also
  replaces Q-Learning's max in the return's target);
- acts on Q(s, ·) − λ Q_C(s, ·) (SARSA and Q-Learning, exploring and greedy), or steps its
  actor on δ − λδ_C (Actor-Critic, whose actor then carries the penalty);
- updates λ at the start of every episode after the first, from the cost J_C of the episode
  that ended (`Lagrangian` or `PIDLagrangian`).

Choices: θ_C starts at 0 and learns without eligibility traces (one-step TD, whatever the
learner's λ); λ is updated once per episode (Stooke et al. update once per batch of
episodes); a constraint is refused inside an iCCA box (`conjure.safety`), whose planner and
risk analyser already decide what is safe.
"""

from __future__ import annotations

from conjure.agents.compiled_agent import LAGRANGIAN, PID_LAGRANGIAN, ConstraintKernel
from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, Interval

__all__ = ["CostConstraint", "Lagrangian", "PIDLagrangian"]

_COST_LIMIT = Interval(float, 0, None, closed="neither")
_GAIN = Interval(float, 0, None)


class CostConstraint(Configurable):
    """A cost limit d per episode and the rule that moves λ (`update_multiplier`)."""

    def compiled_form(self) -> ConstraintKernel:
        """The constraint as the learners' kernels read it."""
        raise NotImplementedError


class Lagrangian(CostConstraint):
    """Dual ascent on λ: λ ← max(0, λ + η (J_C − d)) after each episode of cost J_C.

    Parameters
    ----------
    cost_limit : float
        d, the cost allowed per episode, in (0, inf).
    multiplier_step_size : float, default 0.05
        η, in (0, inf).

    Examples
    --------
    >>> Lagrangian(cost_limit=0.1).compiled_form().cost_limit
    0.1
    """

    parameter_constraints = {
        "cost_limit": _COST_LIMIT,
        "multiplier_step_size": Interval(float, 0, None, closed="neither"),
    }

    def __init__(self, *, cost_limit: float, multiplier_step_size: float = 0.05):
        self.cost_limit = cost_limit
        self.multiplier_step_size = multiplier_step_size

    def compiled_form(self) -> ConstraintKernel:
        """D and η for the learners' kernels."""
        return ConstraintKernel(
            kind=LAGRANGIAN,
            cost_limit=float(self.cost_limit),
            step_size=float(self.multiplier_step_size),
            kp=0.0,
            ki=0.0,
            kd=0.0,
        )


class PIDLagrangian(CostConstraint):
    """λ from a PID controller on J_C − d (Stooke, Achiam and Abbeel 2020, Algorithm 2).

    After each episode of cost J_C: Δ = J_C − d; I ← max(0, I + Δ); ∂ = max(0, J_C − J_prev);
    λ = max(0, K_p Δ + K_i I + K_d ∂). With K_p = K_d = 0 it is the `Lagrangian` with
    η = K_i; K_p damps the overshoot of λ (and of the cost) that the integral alone gives.

    Parameters
    ----------
    cost_limit : float
        d, the cost allowed per episode, in (0, inf).
    kp, ki, kd : float, default 0.1, 0.05, 0.0
        The gains, each in [0, inf); at least one positive.

    Examples
    --------
    >>> PIDLagrangian(cost_limit=0.1, kp=0.5).compiled_form().kp
    0.5
    """

    parameter_constraints = {"cost_limit": _COST_LIMIT, "kp": _GAIN, "ki": _GAIN, "kd": _GAIN}

    def __init__(self, *, cost_limit: float, kp: float = 0.1, ki: float = 0.05, kd: float = 0.0):
        self.cost_limit = cost_limit
        self.kp = kp
        self.ki = ki
        self.kd = kd

    def validate_params(self) -> None:
        """Check each parameter, and that some gain is positive (else λ stays 0)."""
        super().validate_params()
        if self.kp == self.ki == self.kd == 0:
            raise InvalidParameterError(
                "PIDLagrangian needs a positive gain (kp, ki or kd); with all three 0 the "
                "multiplier λ stays 0 and the constraint does nothing."
            )

    def compiled_form(self) -> ConstraintKernel:
        """D and the gains for the learners' kernels."""
        return ConstraintKernel(
            kind=PID_LAGRANGIAN,
            cost_limit=float(self.cost_limit),
            step_size=0.0,
            kp=float(self.kp),
            ki=float(self.ki),
            kd=float(self.kd),
        )
