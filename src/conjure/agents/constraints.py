"""Cost constraints of the linear TD learners: a Lagrange multiplier, or Sauté's budget.

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

`Saute` instead augments the state with the remaining budget (Sootla et al. 2022): no cost
critic and no λ; the learner acts and learns on (s, z) with one block of θ (and ω) per
budget bin and a reshaped reward (`Saute`'s Notes).
"""

from __future__ import annotations

from conjure.agents.compiled_agent import LAGRANGIAN, PID_LAGRANGIAN, SAUTE, ConstraintKernel
from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, Interval

__all__ = ["CostConstraint", "Lagrangian", "PIDLagrangian", "Saute"]

_COST_LIMIT = Interval(float, 0, None, closed="neither")
_GAIN = Interval(float, 0, None)


class CostConstraint(Configurable):
    """A cost limit d per episode for the linear TD learners (Algorithms 10-12)."""

    def compiled_form(self) -> ConstraintKernel:
        """The constraint as the learners' kernels read it."""
        raise NotImplementedError


class Lagrangian(CostConstraint):
    """Dual ascent on λ: λ ← max(0, λ + η (J_C − d)) after each episode of cost J_C.

    The learner (Algorithms 10-12) acts on Q − λQ_C (module docstring).

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


class Saute(CostConstraint):
    """Sauté RL: the state augmented with the remaining budget (Sootla et al. 2022).

    The learner acts and learns on (s, z), z the share of the per-episode cost limit d still
    unspent, with the reward replaced by ``unsafe_reward`` once the budget is spent, so that
    with ``unsafe_reward`` low enough the best policy of the augmented MDP keeps
    Σ_t c_t ≤ d almost surely (Sootla et al. 2022). The learners (Algorithms 10-12) are
    unchanged but for their features, their target's reward and their weights' blocks.

    Parameters
    ----------
    cost_limit : float
        d, the cost allowed per episode, in (0, inf).
    unsafe_reward : float, default -1.0
        The reward of every step after which z ≤ 0, in (-inf, inf).
    num_budget_bins : int, default 4
        B, the equal bins of z in (0, 1], in [1, inf); one more bin holds z ≤ 0.

    Notes
    -----
    - z_0 = 1 at an episode's start and z_{t+1} = z_t − c_t/d, kept as z = 1 − spent/d with
      spent = Σ c so far in the episode (the run loop's ``episode_cost``). Choice: no budget
      discount (Sootla et al. divide by γ each step): d is an undiscounted limit per episode.
    - r̃_t = r_t if z_{t+1} > 0, else ``unsafe_reward`` (the budget after the step, as
      OmniSafe's Saute adapter); the learner's TD target uses r̃ in place of r.
    - Choice: z enters the linear features as φ(s) ⊗ onehot(b(z)), b(z) ∈ {0, ..., B}
      (`conjure.agents.compiled_agent.budget_bin`: 0 for z ≤ 0, bin B for z = 1). θ (and
      Actor-Critic's ω) holds B + 1 blocks of n rows, block b the rows [b·n, (b + 1)·n), all
      at the learner's ``initial_weight``: Q(s, z, ·) = θ_{b(z)}ᵀφ(s), and the target at s'
      reads θ_{b(z')}. ``weights_`` is every block.
    - z' is not in the `Transition` that ``learn`` gets after ``act(s')`` chose a'; the run
      loop tells the learner the episode's cost before every ``act``
      (``Agent.observe_episode_cost``) and the learner keeps the spent budgets of the last two
      learning states and of the last greedy one (a policy check never moves the learning
      episode's). The compiled loop reads its own episode cost.
    - Refused (one-line `IncompatibleComponentsError`): an adaptive representation (θ's
      blocks would each have to grow with it) and eligibility traces (a trace keyed by
      (feature, action) would have to carry the block it was set in).

    Examples
    --------
    >>> Saute(cost_limit=2.0, num_budget_bins=4).compiled_form().num_budget_bins
    4
    """

    parameter_constraints = {
        "cost_limit": _COST_LIMIT,
        "unsafe_reward": Interval(float, None, None),
        "num_budget_bins": Interval(int, 1, None),
    }

    def __init__(self, *, cost_limit: float, unsafe_reward: float = -1.0, num_budget_bins: int = 4):
        self.cost_limit = cost_limit
        self.unsafe_reward = unsafe_reward
        self.num_budget_bins = num_budget_bins

    def compiled_form(self) -> ConstraintKernel:
        """D, the unsafe reward and B for the learners' kernels."""
        return ConstraintKernel(
            kind=SAUTE,
            cost_limit=float(self.cost_limit),
            unsafe_reward=float(self.unsafe_reward),
            num_budget_bins=int(self.num_budget_bins),
        )
