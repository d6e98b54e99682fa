"""BlocksWorld: build a colour-ordered tower of blocks (Geramifard 2012, Section 4.1.4)."""

from __future__ import annotations

from math import comb, factorial
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Domain, DomainSpec
from conjure.core.params import EPISODE_STEPS, Constraint, Interval
from conjure.domains._blocks_kernels import (
    BlocksConstants,
    blocks_fill_legal_mask,
    blocks_legal_actions,
    blocks_masked_transition,
    blocks_reset,
)
from conjure.domains.action_masking import ActionMasking
from conjure.domains.compiled_domain import BLOCKS, DomainKernel, KeptCompiledForm, domain_kernel

__all__ = ["BlocksWorld", "blocks_world_state_action_count"]

_MALFORMED = {
    1: "a block without exactly one support (each row of On must hold one 1)",
    2: "two blocks on the same block",
    3: "a cycle of blocks that never reaches the table",
}


def blocks_world_state_action_count(num_blocks: int = 6) -> int:
    """Return the thesis's tabular size b² Σ_{i=1..b} C(b, i) i^(b−i) (b−i)! (Section 4.1.4).

    Examples
    --------
    >>> blocks_world_state_action_count(6)
    368316
    """
    b = num_blocks
    return b * b * sum(comb(b, i) * i ** (b - i) * factorial(b - i) for i in range(1, b + 1))


class BlocksWorld(KeptCompiledForm, ActionMasking, Domain):
    """Stack ``num_blocks`` blocks into the tower 0 (on the table), 1 on 0, 2 on 1, ...

    Geramifard (2012), Section 4.1.4 and Figure 4-2 (T:2486); spec section 4.1 (after RLPy's
    ``BlocksWorld``). The episode starts with every block on the table. Action move(b, d) puts
    clear block b onto clear block d ≠ b or onto the table; with probability
    ``drop_probability`` (30%) the block is dropped and lands on the table instead. Every move
    earns −0.001; the move that completes the tower earns +1 and ends the episode. γ = 1 and
    episodes are capped at 1000 moves.

    Parameters
    ----------
    num_blocks : int, default=6
        b, the number of blocks, in [2, 16]; there are b² actions and b² state dimensions.
    drop_probability : float, default=0.3
        Probability in [0, 1] that a move drops the block onto the table.
    step_reward : float, default=-0.001
        Reward of every move that does not complete the tower; any finite float.
    goal_reward : float, default=1.0
        Reward of the move that completes the tower; any finite float.
    discount : float, default=1.0
        γ in [0, 1].
    max_episode_steps : int, default=1000
        Episode cap, in [1, inf).
    illegal_action : {"raise", "ignore", "penalize"}, default="raise"
        What an illegal move does: raise, or a no-op step with reward 0 or
        −``illegal_action_penalty`` (`conjure.domains.action_masking`).
    illegal_action_penalty : float, default=1.0
        Penalty in [0, inf) of ``illegal_action="penalize"``.

    Attributes
    ----------
    domain_spec : DomainSpec
        b² binary dimensions with bounds [0, 1], b² actions, ``has_action_constraints=True``.

    Notes
    -----
    ==========  =============  ===================================================
    Symbol      Name           Meaning
    ==========  =============  ===================================================
    On(i, j)    obs[i·b + j]   1.0 if block i sits on block j; On(i, i): on table
    move(b, d)  action b·b + d move block b onto d (d = b: onto the table)
    γ           discount       1.0
    ==========  =============  ===================================================

    - Choice: the thesis prints the step reward as "10^-3"; it is −0.001 (RLPy, citing the
      ICML-11 paper, and common sense: a positive step reward would reward dawdling).
    - Choice: the goal reward replaces the step reward on the completing move (RLPy).
    - Choice: the state is the thesis's 36-dimensional On(·,·) vector with the diagonal
      On(i, i) meaning "i is on the table" (RLPy's encoding), so every row holds exactly one 1
      and the initial features On(·,·) number b² (6 × 6 × 36 actions = 1296, as the thesis).
    - Choice: action a = b·n + d (row-major, so a successful move a sets ``obs[a] = 1``);
      move(b, b) means "onto the table" and is illegal for a block already on the table, which
      leaves exactly b² actions (36).
    - Choice: legality follows the thesis: b ≠ d (or d = table) and both clear. Illegal moves
      raise `InvalidParameterError` unless ``illegal_action`` says otherwise;
      ``action_space.sample()`` draws only legal moves; ``action_masks()`` and
      ``info["action_mask"]`` give them as a bool mask (`conjure.domains.action_masking`).
    - Choice: one uniform draw per move decides the drop, even for a move onto the table.
    - Note: ``state_action_count()`` is the thesis's formula (368,316 for 6 blocks). It counts
      more arrangements than exist: 6 labelled blocks form Σ_k L(6, k) = 4051 towers-of-stacks
      (Lah numbers), not 10,231; we report the thesis's number.

    Complexity: Θ(b²) per step (one compiled pass: the move, then the new state's legal mask);
    `legal_actions` reads that mask for the current state and takes one Θ(b²) pass otherwise.

    Examples
    --------
    >>> domain = BlocksWorld(drop_probability=0.0)
    >>> obs, info = domain.reset(seed=0)
    >>> int(obs.sum()), domain.legal_actions(obs).size
    (6, 30)
    >>> obs, reward, terminated, truncated, info = domain.step(1 * 6 + 0)  # block 1 onto 0
    >>> bool(obs[6]), reward, terminated
    (True, -0.001, False)
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {
        "num_blocks": Interval(int, 2, 16),
        "drop_probability": Interval(float, 0.0, 1.0),
        "step_reward": Interval(float, None, None),
        "goal_reward": Interval(float, None, None),
        "discount": Interval(float, 0.0, 1.0),
        "max_episode_steps": EPISODE_STEPS,
        **ActionMasking.masking_constraints,
    }

    def __init__(
        self,
        *,
        num_blocks: int = 6,
        drop_probability: float = 0.3,
        step_reward: float = -0.001,
        goal_reward: float = 1.0,
        discount: float = 1.0,
        max_episode_steps: int = 1000,
        illegal_action: str = "raise",
        illegal_action_penalty: float = 1.0,
    ) -> None:
        self.num_blocks = num_blocks
        self.drop_probability = drop_probability
        self.step_reward = step_reward
        self.goal_reward = goal_reward
        self.discount = discount
        self.max_episode_steps = max_episode_steps
        self.illegal_action = illegal_action
        self.illegal_action_penalty = illegal_action_penalty
        self._build()

    def _build(self) -> None:
        """Validate the parameters and build the spaces, the spec and the start state."""
        self.validate_params()
        for name in ("step_reward", "goal_reward"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise InvalidParameterError(
                    f"`BlocksWorld.{name}` must be a finite float; got {value!r}."
                )
        n = int(self.num_blocks)
        self._n = n
        self._drop = float(self.drop_probability)
        self._step_reward = float(self.step_reward)
        self._goal_reward = float(self.goal_reward)
        self._constants = BlocksConstants(
            num_blocks=n,
            drop=self._drop,
            step_reward=self._step_reward,
            goal_reward=self._goal_reward,
        )
        dims = n * n
        low = np.zeros(dims, dtype=np.float64)
        high = np.ones(dims, dtype=np.float64)
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)
        self.domain_spec = DomainSpec(
            name=f"BlocksWorld({n})",
            low=low,
            high=high,
            is_discrete=np.ones(dims, dtype=bool),
            num_actions=dims,
            discount=float(self.discount),
            max_episode_steps=int(self.max_episode_steps),
            has_action_constraints=True,
        )
        # On vector, on, above; and the legal moves: shared with the compiled form
        self._dstate = np.empty(dims + 2 * n, dtype=np.int64)
        self._mask = np.empty(dims, dtype=np.int8)
        self._set_start()
        self._set_action_space()

    def _set_start(self) -> np.ndarray:
        """Every block on the table; returns the observation."""
        obs = np.empty(self._n * self._n)
        blocks_reset(self._n, self._dstate, obs)
        blocks_fill_legal_mask(self._dstate, self._n, self._mask)
        return obs

    def state_action_count(self) -> int:
        """Return the thesis's tabular size |S × A| (368,316 for 6 blocks), Section 4.1.4."""
        return blocks_world_state_action_count(self._n)

    compiled_methods = ("step", "reset", "legal_actions")

    def compiled_form(self) -> DomainKernel:
        """BlocksWorld for the compiled loop (`blocks_masked_transition`, as ``step``).

        `BlocksConstants` (n, drop probability, step reward, goal reward), as ``step`` uses
        them; state the On(·,·) indicators, then each block's support and the block above
        each block; mask the legal moves (`KeptCompiledForm`).
        """
        n = self._n
        return self._kept_form(
            lambda: domain_kernel(
                BLOCKS,
                n * n,
                constants=self._constants,
                state=self._dstate,
                mask=self._mask,
                num_units=n,
            )
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode with every block on the table."""
        super().reset(seed=seed)
        return self._set_start(), self._with_mask({})

    def _legal_actions_of(self, state: np.ndarray) -> np.ndarray:
        legal, code = blocks_legal_actions(state, self._n)
        if code:
            raise InvalidParameterError(
                f"BlocksWorld.legal_actions got an impossible state: {_MALFORMED[code]}."
            )
        return legal

    def _observed_state(self) -> np.ndarray:
        return self._dstate[: self._n * self._n]  # the On(·,·) indicators

    def describe_action(self, action: int) -> str:
        """Return the move in words, e.g. ``move(2, 0)`` or ``move(1, table)``."""
        block, target = divmod(int(action), self._n)
        return f"move({block}, {'table' if target == block else target})"

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move block b onto d (``action = b·n + d``); with probability 0.3 it drops."""
        a = self.check_action(action)
        if not self._mask[a]:
            return self._reject(
                a, "both blocks must be clear and a block on the table cannot move to the table"
            )
        obs = np.empty(self._n * self._n)
        reward, terminated = blocks_masked_transition(
            self._constants, self._dstate, a, obs, self.np_random.random(), self._mask
        )
        return obs, reward, terminated, False, self._with_mask({})
