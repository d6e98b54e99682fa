"""Legal actions for outside agents: ``action_masks()``, ``info["action_mask"]``, illegal steps.

Domains with action constraints (BlocksWorld, Persistent Surveillance, Rescue Mission, UAV
missions; Geramifard 2012, Section 4.1.4 and Section 5.3.5) tell conjure's own learners the
legal actions through `Domain.legal_actions`. Agents from other libraries know nothing of that
method; the ecosystem's conventions are:

- ``env.action_masks()``: a bool array of shape ``(num_actions,)``, True where the action is
  legal in the current state. sb3-contrib's ``MaskablePPO`` reads exactly this method (through
  ``get_wrapper_attr``, so it works on ``gymnasium.make(...)`` environments and vector envs).
- ``info["action_mask"]``: the same bool array, in the info of ``reset`` and of every ``step``
  (for agents that read masks from the info dict, as PettingZoo and Gymnasium's examples do).

What an illegal action does is the domain parameter ``illegal_action``:

- ``"raise"`` (default, conjure's learners never choose one): `InvalidParameterError` naming the
  action and the legal ones.
- ``"ignore"``: the step is a no-op: the state is unchanged, the reward is 0, the episode does
  not end, and ``info["illegal_action"]`` is True. For plain PPO/DQN clients.
- ``"penalize"``: the same no-op, with reward −``illegal_action_penalty``, so that an unmasked
  agent learns to avoid illegal actions.

The thesis never lets an agent take an illegal action (its learners choose among the legal
ones), so these modes only matter to outside agents; with ``"raise"`` a domain behaves as before.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, ClassVar

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Constraint, Options, Predicate
from conjure.domains._legal_space import LegalDiscrete

__all__ = ["ILLEGAL_ACTION_MODES", "ActionMasking"]

#: The values of a domain's ``illegal_action`` parameter.
ILLEGAL_ACTION_MODES: tuple[str, ...] = ("raise", "ignore", "penalize")


def _is_penalty(value: Any) -> bool:
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value >= 0
    )


class ActionMasking:
    """Mixin for domains with legal-action constraints: masks and illegal-action handling.

    Geramifard (2012), Section 4.1.4 (the constrained domains BlocksWorld, Persistent
    Surveillance, Rescue Mission) and Section 5.3.5 (UAV missions). A domain lists it before
    its `Domain` base, merges `masking_constraints` into its ``parameter_constraints`` and takes
    the two parameters below in its constructor. Its ``_mask`` is the legal actions of its
    current state (1 or True where legal), one compiled pass per state (kept up to date as the
    state changes, or computed at its first read after a change, `UAVMission`); it builds its
    ``action_space`` with `_set_action_space`, and implements ``_observed_state`` (its current
    state, as the observation shows it), ``_legal_actions_of`` (the legal
    actions of any other state, validated) and ``describe_action``. Its ``step`` returns
    ``self._reject(action, rule)`` for an action that ``_mask`` rules out and
    ``self._with_mask(info)`` as the info of every other step; ``reset`` returns
    ``self._with_mask(info)`` too.

    Parameters
    ----------
    illegal_action : {"raise", "ignore", "penalize"}, default="raise"
        What ``step`` does with an action that is illegal in the current state: raise
        `InvalidParameterError` naming the action and the legal ones; or take a no-op step
        (state unchanged, not terminated) with reward 0 (``"ignore"``) or
        −``illegal_action_penalty`` (``"penalize"``), marked ``info["illegal_action"] = True``.
    illegal_action_penalty : float, default=1.0
        The penalty in [0, inf) of ``"penalize"`` (finite); unused by the other modes. Scale it
        to the domain's rewards (BlocksWorld's goal is +1, Persistent Surveillance's crash −50).

    Notes
    -----
    - Choice: an ignored or penalised step leaves the state, including any time step t in it
      (Rescue Mission, UAV missions), unchanged: no time passes in the domain. The step still
      counts toward the episode cap (Gymnasium's ``TimeLimit`` and conjure's run loop truncate
      at ``max_episode_steps``), so an agent that keeps choosing illegal actions cannot stall an
      episode forever when the domain runs under either.
    - Choice: a rejected step enters no failure state, so it carries no ``"cost"``.
    - Choice: a rejected step draws no random numbers, except in `UAVMission`, whose every step
      draws its 2n uniforms before the legality test (so that its compiled kernel replays it).
    - Choice: ``info["action_mask"]`` is a fresh array at every call (an agent may keep it);
      ``action_masks()`` returns the mask of the current state, so after the last step of an
      episode it is the mask of the terminal state.
    - Choice: legality is computed once per state. ``legal_actions(state)`` of a state equal
      to the current one (same shape and the same float64 bytes; values are compared, never
      the array's identity) reads ``_mask``, the mask the step already computed; any other
      state gets its own compiled pass. A fresh array either way.
    """

    #: The compiled loop picks only legal actions, so the illegal-action handling never runs
    #: there (`conjure.core.compiled_form`).
    compiled_irrelevant_params: ClassVar[frozenset[str]] = frozenset(
        {"discount", "max_episode_steps", "illegal_action", "illegal_action_penalty"}
    )

    #: Constraints of the two parameters; domains merge them into ``parameter_constraints``.
    masking_constraints: ClassVar[dict[str, Constraint]] = {
        "illegal_action": Options(ILLEGAL_ACTION_MODES),
        "illegal_action_penalty": Predicate(_is_penalty, "a finite float in [0, inf)"),
    }

    illegal_action: str
    illegal_action_penalty: float
    #: The legal actions of the current state (nonzero where legal), kept by the domain.
    _mask: np.ndarray

    def _observed_state(self) -> np.ndarray:
        """Return the domain's current state array (not a copy) that observations show."""
        raise NotImplementedError

    def _legal_actions_of(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted legal actions of a float64 ``state`` of the right shape, or raise."""
        raise NotImplementedError

    def _set_action_space(self) -> None:
        """Build the action space, whose ``sample()`` draws legal actions (after ``_mask``)."""
        legal = self._current_legal()
        self.action_space = LegalDiscrete(self._mask.shape[0], self._current_legal, legal)

    def _current_legal(self) -> np.ndarray:
        """Return the sorted legal actions of the current state (from ``_mask``)."""
        return self._mask.nonzero()[0].astype(np.int64, copy=False)  # 1-D: flatnonzero's work

    def _current_mask(self) -> np.ndarray:
        """Return a new bool array, True at the legal actions of the current state."""
        return self._mask.astype(bool)

    def _current_observation(self) -> np.ndarray:
        """Return a copy of the current observation."""
        return self._observed_state().astype(np.float64)

    def legal_actions(self, state: np.ndarray) -> np.ndarray:
        """Return the sorted legal actions of ``state`` (one compiled pass per state).

        Examples
        --------
        >>> from conjure.domains import BlocksWorld
        >>> domain = BlocksWorld(num_blocks=2)
        >>> observation, _ = domain.reset(seed=0)
        >>> domain.legal_actions(observation).tolist()  # the current state: read from its mask
        [1, 2]
        >>> domain.legal_actions([0.0, 1.0, 0.0, 1.0]).tolist()  # block 0 on block 1
        [0]
        """
        name = type(self).__name__
        try:
            array = np.asarray(state, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"{name}.legal_actions expects a numeric state vector; got {state!r}."
            ) from None
        current = self._observed_state()
        if array.shape != current.shape:
            raise InvalidParameterError(
                f"{name}.legal_actions expects a state of shape {current.shape}; got shape "
                f"{array.shape}."
            )
        if array.tobytes() == current.astype(np.float64, copy=False).tobytes():
            return self._current_legal()
        return self._legal_actions_of(array)

    def action_masks(self) -> np.ndarray:
        """Return the legal actions of the current state as a bool array (MaskablePPO's method).

        Examples
        --------
        >>> from conjure.domains import BlocksWorld
        >>> domain = BlocksWorld(num_blocks=2)
        >>> _, info = domain.reset(seed=0)
        >>> domain.action_masks().tolist(), info["action_mask"].tolist()  # move(1, 0) or (0, 1)
        ([False, True, True, False], [False, True, True, False])
        """
        return self._current_mask()

    def _with_mask(self, info: dict[str, Any]) -> dict[str, Any]:
        """Add the current state's ``"action_mask"`` to ``info`` and return it."""
        info["action_mask"] = self._current_mask()
        return info

    def _reject(
        self, action: int, rule: str
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Raise for an illegal ``action``, or take the no-op step of ``illegal_action``.

        ``rule`` explains legality in the domain's words, for the error message.
        """
        mask = self._current_mask()
        if self.illegal_action == "raise":
            name = type(self).__name__
            words = self.describe_action(action)
            words = words if words.startswith("(") else f"({words})"
            raise InvalidParameterError(
                f"{name}.step: action {action} {words} is illegal in the "
                f"current state ({rule}); legal actions: {np.flatnonzero(mask).tolist()}. "
                f"Choose among env.action_masks(), or build {name}(illegal_action='ignore' or "
                f"'penalize') to make illegal actions no-ops."
            )
        is_penalized = self.illegal_action == "penalize"
        reward = -float(self.illegal_action_penalty) if is_penalized else 0.0
        info = {"action_mask": mask, "illegal_action": True}
        return self._current_observation(), reward, False, False, info

    def describe_action(self, action: int) -> str:
        """Return the action in the domain's words."""
        raise NotImplementedError
