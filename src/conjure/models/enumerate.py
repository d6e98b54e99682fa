"""Build a `TabularModel` by enumerating a domain's states and one-step outcomes (Section 2.1)."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import scipy.sparse as sp

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.models.tabular_model import TabularModel

__all__ = ["enumerate_model"]


def enumerate_model(domain: Any, *, max_states: int = 1_000_000) -> TabularModel:
    """Enumerate the states reachable from the start states and return the exact model.

    The domain must provide ``start_states() -> [(probability, state)]`` and
    ``outcomes(state, action) -> [(probability, next_state, reward, terminated)]``; states are
    observation vectors. Expected rewards are R(s, a) = Σ p · r (Eq. 2.7's R vector).

    Parameters
    ----------
    domain : Domain
        The domain to enumerate.
    max_states : int, default 1000000
        Stop with an error beyond this many states.

    Notes
    -----
    - Choice: a transition flagged terminated leads to a terminal state that absorbs with
      reward 0 under every action (Domain semantics: the episode ends there).
    - Choice: states are numbered in breadth-first order from the start states.

    Complexity
    ----------
    Θ(|S||A| k) Python calls for k outcomes per pair; domains with |S| ≥ 10⁵ should build
    their model vectorised (GridWorld does).

    Examples
    --------
    >>> from conjure.domains import ChainMDP
    >>> enumerate_model(ChainMDP(num_states=3)).num_states
    3
    """
    name = type(domain).__name__
    if not (
        callable(getattr(domain, "outcomes", None))
        and callable(getattr(domain, "start_states", None))
    ):
        raise IncompatibleComponentsError(
            f"{name} cannot list its states and one-step outcomes (it has no outcomes() and "
            f"start_states()), so it has no tabular model; use a sampled planner (Alg 6, 8, 9, "
            f"13) or discretise it."
        )
    num_actions = int(domain.domain_spec.num_actions)
    index: dict[bytes, int] = {}
    states: list[np.ndarray] = []
    terminal: list[bool] = []
    queue: deque[int] = deque()

    def intern(state: Any, is_terminal: bool) -> int:
        array = np.asarray(state, dtype=np.float64).reshape(-1)
        key = array.tobytes()
        found = index.get(key)
        if found is None:
            if len(states) >= max_states:
                raise InvalidParameterError(
                    f"enumerate_model: {name} has more than max_states={max_states} states."
                )
            found = len(states)
            index[key] = found
            states.append(array)
            terminal.append(bool(is_terminal))
            queue.append(found)
        elif is_terminal:
            terminal[found] = True
        return found

    start = [(float(p), intern(s, False)) for p, s in domain.start_states()]
    rows: list[list[int]] = [[] for _ in range(num_actions)]
    cols: list[list[int]] = [[] for _ in range(num_actions)]
    probs: list[list[float]] = [[] for _ in range(num_actions)]
    rewards: dict[tuple[int, int], float] = {}
    expanded: set[int] = set()
    while queue:
        s = queue.popleft()
        if s in expanded:
            continue
        expanded.add(s)
        if terminal[s]:
            continue
        for a in range(num_actions):
            for p, next_state, reward, terminated in domain.outcomes(states[s], a):
                if p == 0.0:
                    continue
                t = intern(next_state, bool(terminated))
                rows[a].append(s)
                cols[a].append(t)
                probs[a].append(float(p))
                rewards[(s, a)] = rewards.get((s, a), 0.0) + float(p) * float(reward)
    n = len(states)
    is_terminal = np.array(terminal, dtype=bool)
    reward_table = np.zeros((n, num_actions))
    for (s, a), r in rewards.items():
        reward_table[s, a] = r
    absorbing = np.flatnonzero(is_terminal)
    matrices = []
    for a in range(num_actions):
        r = np.concatenate([np.array(rows[a], dtype=np.int64), absorbing])
        c = np.concatenate([np.array(cols[a], dtype=np.int64), absorbing])
        v = np.concatenate([np.array(probs[a]), np.ones(absorbing.size)])
        matrices.append(sp.csr_matrix((v, (r, c)), shape=(n, n)))
    start_distribution = np.zeros(n)
    for p, s in start:
        start_distribution[s] += p
    return TabularModel(
        transitions=matrices,
        rewards=reward_table,
        is_terminal=is_terminal,
        discount=float(domain.domain_spec.discount),
        states=np.array(states),
        start_distribution=start_distribution,
        name=domain.domain_spec.name,
        spec=domain.domain_spec,
    )
