"""A tiny chain MDP with a known optimal value function, for tests."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import EPISODE_STEPS, Constraint, Interval, Options
from conjure.domains._kernels import chain_move
from conjure.domains.compiled_domain import (
    CHAIN,
    ChainConstants,
    DomainKernel,
    KeptCompiledForm,
    domain_kernel,
)

if TYPE_CHECKING:  # the model and SciPy load when `model` is first called
    from conjure.models.tabular_model import TabularModel

__all__ = ["ChainMDP"]


class ChainMDP(KeptCompiledForm, Domain):
    """Walk right along a chain of states to the terminal end; V* is known in closed form.

    A test domain for the Bellman equation, Geramifard (2012) Section 2.1, Equation 2.5. States
    are 0 .. n−1, the episode starts in 0 and state n−1 is terminal. Action 0 moves one state
    right and earns ``step_reward``; with ``num_actions = 2``, action 1 stays put and earns 0.
    With probability ``slip`` a move fails: the agent stays put and earns 0.

    For n = 4, γ = 0.9, reward 1 and no slip, V* = Q*(·, 0) = [2.71, 1.9, 1, 0] and
    Q*(s, 1) = 0.9 V*(s).

    Parameters
    ----------
    num_states : int, default=4
        n, the number of states, in [2, inf).
    num_actions : {1, 2}, default=1
        1: only "move right"; 2: also "stay".
    step_reward : float, default=1.0
        Reward of a successful move right; any finite float.
    slip : float, default=0.0
        Probability in [0, 1) that a move right fails (stay put, reward 0).
    discount : float, default=0.9
        γ in [0, 1].
    max_episode_steps : int, default=100
        Episode cap, in [1, inf).

    Attributes
    ----------
    domain_spec : DomainSpec
        One discrete dimension with bounds [0, n − 1].

    Notes
    -----
    The optimal values follow by backward induction from V*(n−1) = 0:

        M(s) = (1 − p)(r + γ V*(s+1)) / (1 − p γ),  V*(s) = max(M(s), 0 if "stay" exists else M(s)),

    since staying forever earns 0. Then Q*(s, 0) = (1 − p)(r + γ V*(s+1)) + p γ V*(s) and
    Q*(s, 1) = γ V*(s); both are 0 in the terminal state.

    - Choice: a failed move (``slip``) earns 0, like staying.
    - Choice: the observation is the state index as a float64 vector of shape (1,).

    Examples
    --------
    >>> ChainMDP().optimal_values().round(2).tolist()
    [2.71, 1.9, 1.0, 0.0]
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "num_states": Interval(int, 2, None),
        "num_actions": Options((1, 2)),
        "step_reward": Interval(float, None, None),
        "slip": Interval(float, 0.0, 1.0, closed="left"),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": EPISODE_STEPS,
    }

    def __init__(
        self,
        *,
        num_states: int = 4,
        num_actions: int = 1,
        step_reward: float = 1.0,
        slip: float = 0.0,
        discount: float = 0.9,
        max_episode_steps: int = 100,
    ) -> None:
        self.num_states = num_states
        self.num_actions = num_actions
        self.step_reward = step_reward
        self.slip = slip
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self._build()

    def _build(self) -> None:
        """Validate the parameters and build the spaces and spec."""
        self.validate_params()
        n = int(self.num_states)
        low = np.zeros(1, dtype=np.float64)
        high = np.array([n - 1], dtype=np.float64)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.action_space = spaces.Discrete(int(self.num_actions))
        self.domain_spec = DomainSpec(
            name="ChainMDP",
            low=low,
            high=high,
            is_discrete=[True],
            num_actions=int(self.num_actions),
            discount=float(self.discount),
            max_episode_steps=int(self.max_episode_steps),
        )
        self._position = np.zeros(1, dtype=np.int64)  # the state, shared with the form
        self._slip = float(self.slip)
        self._step_reward = float(self.step_reward)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode in state 0."""
        super().reset(seed=seed)
        self._position[0] = 0
        return np.array([0.0]), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move right (action 0) or stay (action 1)."""
        a = self.check_action(action)
        last = self.num_states - 1
        state, reward = chain_move(
            last, self._step_reward, self._slip, self._position[0], a, self.np_random
        )
        self._position[0] = state
        return np.array([float(state)]), reward, state == last, False, {}

    compiled_methods = ("step", "reset")

    def return_bounds(self) -> tuple[float, float]:
        """(lowest, highest) return of any episode (cuts intervals only).

        An episode makes at most k = min(n − 1, cap) successful moves right, each earning r,
        and nothing else earns a reward: the return lies between k·min(r, 0) and k·max(r, 0).

        Examples
        --------
        >>> ChainMDP(num_states=8).return_bounds()
        (0.0, 7.0)
        """
        moves = min(int(self.num_states) - 1, int(self.max_episode_steps))
        r = float(self.step_reward)
        return moves * min(r, 0.0), moves * max(r, 0.0)

    def compiled_form(self) -> DomainKernel:
        """The chain for the compiled loop: `ChainConstants` (n, step reward, slip), the state.

        Kept (`KeptCompiledForm`).
        """
        constants = ChainConstants(
            num_states=int(self.num_states),
            step_reward=float(self._step_reward),
            slip=float(self._slip),
        )
        return self._kept_form(
            lambda: domain_kernel(
                CHAIN, int(self.num_actions), constants=constants, state=self._position
            )
        )

    def start_states(self) -> list[tuple[float, np.ndarray]]:
        """Return [(1, state 0)]: the start distribution, for `enumerate_model`."""
        return [(1.0, np.array([0.0]))]

    def outcomes(self, state: Any, action: int) -> list[tuple[float, np.ndarray, float, bool]]:
        """Return the one-step outcomes [(p, s', r, terminated)] of ``action`` in ``state``."""
        s, last = round(float(np.asarray(state).reshape(-1)[0])), self.num_states - 1
        stay = (np.array([float(s)]), 0.0, s == last)
        if s >= last or action != 0:
            return [(1.0, *stay)]
        move = (np.array([float(s + 1)]), float(self.step_reward), s + 1 == last)
        if self.slip == 0.0:
            return [(1.0, *move)]
        return [(1.0 - float(self.slip), *move), (float(self.slip), *stay)]

    def set_state(self, state: Any) -> None:
        """Put the chain in ``state`` (the generative-model hook, Eq. 2.28)."""
        self._position[0] = round(float(np.asarray(state).reshape(-1)[0]))

    def model(self) -> TabularModel:
        """Return the exact `TabularModel`, enumerated from `outcomes` (Section 2.1)."""
        from conjure.models.enumerate import enumerate_model

        return enumerate_model(self)

    def tabular_model(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the exact model (P, R): P[a, s, s'] probabilities and R[a, s] expected rewards.

        The terminal state n − 1 absorbs with reward 0 under every action.
        """
        n, num_actions = int(self.num_states), int(self.num_actions)
        p = float(self.slip)
        transitions = np.zeros((num_actions, n, n))
        rewards = np.zeros((num_actions, n))
        for s in range(n - 1):
            transitions[0, s, s + 1] = 1.0 - p
            transitions[0, s, s] += p
            rewards[0, s] = (1.0 - p) * float(self.step_reward)
            if num_actions == 2:
                transitions[1, s, s] = 1.0
        transitions[:, n - 1, n - 1] = 1.0
        return transitions, rewards

    def optimal_values(self) -> np.ndarray:
        """Return V*(s) for every state (closed form, see Notes)."""
        return self.optimal_q_values().max(axis=1)

    def optimal_q_values(self) -> np.ndarray:
        """Return Q*(s, a) of shape (num_states, num_actions) (closed form, see Notes)."""
        n, gamma, p = int(self.num_states), float(self.discount), float(self.slip)
        r = float(self.step_reward)
        values = np.zeros(n)
        for s in range(n - 2, -1, -1):
            move = (1.0 - p) * (r + gamma * values[s + 1]) / (1.0 - p * gamma)
            values[s] = max(move, 0.0) if self.num_actions == 2 else move
        q = np.zeros((n, int(self.num_actions)))
        for s in range(n - 1):
            q[s, 0] = (1.0 - p) * (r + gamma * values[s + 1]) + p * gamma * values[s]
            if self.num_actions == 2:
                q[s, 1] = gamma * values[s]
        return q
