"""Q-Learning, Geramifard (2012), Algorithm 10 (Watkins 1992)."""

from __future__ import annotations

from conjure.agents import compiled_agent as forms
from conjure.agents.constraints import CostConstraint
from conjure.agents.linear_td import LinearTDAgent
from conjure.core.interfaces import Policy, Representation
from conjure.core.schedules import StepSizeSchedule

__all__ = ["QLearning"]


class QLearning(LinearTDAgent):
    """Off-policy TD control: Q⁺(s, a) = r + γ max_a' Q(s', a') (Algorithm 10).

    Parameters
    ----------
    representation : Representation
        φ, read through its `encode`: binary features or real-valued ones (Gaussian RBF).
    policy : Policy or None, default None
        The behaviour policy π^ε; ``None`` means ``EpsilonGreedy(epsilon=0.1)``.
    step_size : float or StepSizeSchedule, default 0.1
        α in (0, inf), or a schedule (Sections 4.1.4 and 5.3.5).
    initial_weight : float, default 0.0
        θ's initial value.
    constraint : CostConstraint or None, default None
        A cost limit per episode and its multiplier rule (`Lagrangian`, `PIDLagrangian`;
        `conjure.agents.constraints`): a cost critic θ_C and λ.

    Attributes
    ----------
    weights_ : ndarray of shape (n_features, n_actions)
        θ; row f holds feature f's weight for every action (Eq. 2.11).
    representation_ : Representation
        The set-up copy of ``representation``.

    Notes
    -----
    Symbols: θ ``weights_``, φ(s) the representation's features, α ``step_size``, δ the value
    ``learn`` returns.

    - Choice: θ starts at ``initial_weight`` (zero) where Algorithm 10 writes θ ← Random().
    - Choice: the max in line 5 runs over the legal actions of s' when the domain constrains
      actions (``Transition.next_legal_actions``).
    - Q-Learning may diverge with function approximation (Section 2.6.1); ``learn`` raises
      `DivergenceError` as soon as δ is not finite.

    Complexity
    ----------
    Θ(k|A|) per step for k active features (Algorithm 10).

    Examples
    --------
    >>> from conjure.domains import ChainMDP
    >>> from conjure.experiments import run
    >>> from conjure.representations import Tabular
    >>> result = run(domain=ChainMDP(), agent=QLearning(representation=Tabular()),
    ...              budget_steps=300, seed=1)
    >>> int(result.curve["learning_steps"].iloc[-1])
    300
    """

    kernel_kind = forms.Q_LEARNING

    def __init__(
        self,
        *,
        representation: Representation,
        policy: Policy | None = None,
        step_size: float | StepSizeSchedule = 0.1,
        initial_weight: float = 0.0,
        constraint: CostConstraint | None = None,
    ):
        self.representation = representation
        self.policy = policy
        self.step_size = step_size
        self.initial_weight = initial_weight
        self.constraint = constraint
