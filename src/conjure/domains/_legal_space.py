"""A `Discrete` action space whose ``sample()`` draws among the currently legal actions.

Domains with action constraints (BlocksWorld, Persistent Surveillance, Rescue Mission, UAV
missions; thesis Section 4.1.4) raise on an illegal action by default
(`conjure.domains.action_masking`). Gymnasium's ``check_env`` and ordinary user code
call ``action_space.sample()`` without a mask, so the space asks its domain for the legal
actions of the current state whenever no mask is given. ``contains`` is unchanged: it answers
"is this an action index at all", legality is per state (`Domain.legal_actions`).

Choice: an unmasked sample prefers actions that are legal both now and in the start state.
Gymnasium's ``check_env`` (``check_step_determinism``) samples an action, *then* resets and
steps with it, so an action legal only in the current state would be rejected after the reset.
Learners never use ``sample()``: they choose among `Domain.legal_actions`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces

__all__ = ["LegalDiscrete"]


class LegalDiscrete(spaces.Discrete):
    """``Discrete(n)`` whose unmasked ``sample`` draws uniformly among ``current_legal()``.

    Parameters
    ----------
    n : int
        Number of actions.
    current_legal : callable
        Returns the sorted int64 legal actions of the owner's current state (a bound method of
        the domain, so the space pickles and deep-copies with it).
    start_legal : array of int
        The legal actions of the start state.
    """

    def __init__(
        self, n: int, current_legal: Callable[[], np.ndarray], start_legal: np.ndarray
    ) -> None:
        super().__init__(n)
        self.current_legal = current_legal
        self.start_legal = np.asarray(start_legal, dtype=np.int64)

    def sample(self, mask: Any = None, probability: Any = None) -> np.int64:
        """Draw a legal action of the current state (or honour an explicit mask/probability).

        Among the current legal actions, those also legal in the start state are preferred
        (see the module notes); if there are none, any current legal action is drawn.
        """
        if mask is None and probability is None:
            legal = self.current_legal()
            both = np.intersect1d(legal, self.start_legal, assume_unique=True)
            mask = np.zeros(self.n, dtype=np.int8)
            mask[both if both.size else legal] = 1
        return super().sample(mask=mask, probability=probability)
