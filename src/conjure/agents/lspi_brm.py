"""LSPI with Bellman residual minimisation and double sampling (Geramifard 2012, Algorithm 15)."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.agents.batch import action_rows
from conjure.agents.lspi import LSPI
from conjure.core.errors import IncompatibleComponentsError
from conjure.core.interfaces import Transition
from conjure.core.linalg import brm_system

__all__ = ["LSPIBRM", "double_samples"]


def double_samples(transitions: list[Transition]) -> tuple[np.ndarray, np.ndarray]:
    """The double-sampling filter of Algorithm 15, line 3: pair two samples of the same ⟨s, a⟩.

    Returns index arrays (first, second): sample ``first[k]`` gives ⟨s, a, r, s', a'⟩ and
    sample ``second[k]`` (the next occurrence of the same exact s and a) gives ⟨s'', a''⟩.
    Occurrences are paired consecutively without reuse: 1st with 2nd, 3rd with 4th, ...

    Examples
    --------
    >>> s = np.array([0.0])
    >>> t = Transition(s, 0, 0.0, s, 0, False)
    >>> [x.tolist() for x in double_samples([t, t, t])]
    [[0], [1]]
    """
    waiting: dict[tuple[bytes, int], int] = {}
    first, second = [], []
    for i, t in enumerate(transitions):
        key = (np.asarray(t.state, dtype=np.float64).tobytes(), int(t.action))
        j = waiting.pop(key, None)
        if j is None:
            waiting[key] = i
        else:
            first.append(j)
            second.append(i)
    return np.array(first, dtype=np.int64), np.array(second, dtype=np.int64)


class LSPIBRM(LSPI):
    """LSPI whose evaluation minimises the Bellman residual with two independent next states.

    Geramifard (2012), Algorithm 15 with Eqs. 2.41-2.44:
    Ã = (Φ̃ − γP̃Φ̃₁)ᵀ(Φ̃ − γP̃Φ̃₂)/L and b̃ = (Φ̃ − γP̃Φ̃₁)ᵀR̃/L, where P̃Φ̃₁ and P̃Φ̃₂ hold
    φ(s'_i, a'_i) and φ(s''_i, a''_i) of two samples of the same ⟨s_i, a_i⟩.

    Parameters
    ----------
    representation : Representation
        φ(s).
    policy : Policy or None, default None
        Behaviour policy π^ε of ``act``.
    regularization : float, default 1e-6
        λ ≥ 0 added to Ã's diagonal.
    max_iterations : int, default 20
        Cap on iterations, in [1, inf).
    tolerance : float, default 1e-6
        Stop when max |Δθ| < tolerance, in [0, inf).
    fit_every : int or None, default None
        In a run: fit before every policy check (``None``) or after every N new samples.

    Notes
    -----
    - Choice: the filter matches exact states (states must repeat, e.g. discrete domains);
      the reward r_i is the first sample's.
    - Choice (in a run): a fit that finds no ⟨s, a⟩ sampled twice yet keeps θ and waits for
      more samples when every state dimension is discrete; on a domain with a continuous
      dimension, where exact states never repeat, it raises the same clear error as `fit`.
    - Choice: b̃ carries the 1/L of Eq. 2.26 (Eq. 2.44 omits it; θ is unchanged up to λ).

    Complexity
    ----------
    As `LSPI`, with L the number of filtered pairs.

    Examples
    --------
    >>> from conjure.core.interfaces import DomainSpec
    >>> from conjure.representations import Tabular
    >>> spec = DomainSpec(name="one", low=[0.0], high=[0.0], is_discrete=[True], num_actions=1,
    ...                   discount=0.5, max_episode_steps=10)
    >>> s = np.array([0.0])
    >>> batch = [Transition(s, 0, 1.0, s, 0, False)] * 2
    >>> LSPIBRM(representation=Tabular(), regularization=0.0).setup(spec, 0).fit(batch).weights_
    array([[2.]])
    """

    def _fit_samples(self, batch: list[Transition]) -> None:
        if double_samples(batch)[0].size == 0 and np.all(self.spec_.is_discrete):
            return  # no pair yet on a discrete domain: wait for more samples
        self.fit(batch)

    def _prepare(self, batch: list[Transition]) -> dict[str, Any]:
        first, second = double_samples(batch)
        if first.size == 0:
            raise IncompatibleComponentsError(
                "LSPIBRM found no state-action pair sampled twice; the double-sampling filter "
                "(Algorithm 15, line 3) needs repeated ⟨s, a⟩: use a discrete domain or more "
                "samples, or LSPI."
            )
        firsts = [batch[i] for i in first]
        seconds = [batch[i] for i in second]
        data = self._encode(firsts)
        other = self._encode(seconds)
        data["phi_next_2"] = other["phi_next"]
        data["live_2"] = other["live"]
        data["legal_2"] = other["legal"]
        data["next_actions"] = (data["next_actions"], other["next_actions"])
        self.num_pairs_ = int(first.size)
        return data

    def _system(self, data: dict[str, Any], next_actions: Any) -> tuple[sp.csr_matrix, np.ndarray]:
        num_actions = self.spec_.num_actions
        actions_1, actions_2 = next_actions
        phi_bar = action_rows(data["phi"], data["actions"], num_actions)
        next_1 = sp.diags(data["live"]) @ action_rows(data["phi_next"], actions_1, num_actions)
        next_2 = sp.diags(data["live_2"]) @ action_rows(data["phi_next_2"], actions_2, num_actions)
        return brm_system(
            phi_bar,
            sp.csr_matrix(next_1),
            data["rewards"],
            self.spec_.discount,
            sp.csr_matrix(next_2),
        )

    def _next_actions(self, data: dict[str, Any]) -> Any:
        first = self._greedy_next(data["phi_next"], data["legal"])  # line 7: a'
        second = self._greedy_next(data["phi_next_2"], data["legal_2"])  # line 8: a''
        return _Pair(first, second)


class _Pair(tuple):
    """(a', a'') arrays; ``!=`` counts changes in either, for LSPI's stopping rule."""

    def __new__(cls, first: np.ndarray, second: np.ndarray) -> _Pair:
        return super().__new__(cls, (first, second))

    def __ne__(self, other: object) -> np.ndarray:  # type: ignore[override]
        a, b = other  # type: ignore[misc]
        return np.concatenate([self[0] != a, self[1] != b])
