"""Plain-Python reference of online iFDD (Geramifard 2012, Algorithms 19-21, Eq. 4.6).

Written straight from the thesis with frozensets and dicts, for the compiled `OnlineIFDD` and
`RandomExpansion` to match feature for feature. It follows the same documented choices:

- a conjunction is its set of initial features; its parents are the pair that last updated it;
- Alg 19: features within the active set, largest first, ties to the latest discovered, each
  activated only if all its initial features are still uncovered;
- pairs (φ̇[i], φ̇[j]), i < j, in increasing feature id; discovery as soon as ψ_f > ξ;
- fixed rate (Eq. 4.6): n_t = n₀ + ⌊√(C t)⌋; iFDD takes the most relevant potential feature
  (ties to the first seen); Random draws uniformly from a swap-removal list with the same
  counter-based generator.

Also `FlagFeatures`, a tiny binary base representation whose state is a vector of 0/1 flags
and whose active features are the indices of the ones.
"""

from __future__ import annotations

import math

import numpy as np

from conjure.core.interfaces import DomainSpec, Representation

MASK64 = (1 << 64) - 1


def splitmix64(x: int) -> int:
    z = (x + 0x9E3779B97F4A7C15) & MASK64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return z ^ (z >> 31)


def random_index(word: int, draw: int, size: int) -> int:
    z = splitmix64((word + draw * 0xD1B54A32D192ED03) & MASK64)
    u = float(z >> 11) * (1.0 / 9007199254740992.0)
    return int(u * size)


class OracleIFDD:
    """Algorithms 19-21 and Eq. 4.6 on frozensets."""

    def __init__(
        self,
        num_initial: int,
        *,
        threshold: float = 1.0,
        relevance: str = "ifdd",
        sparsify: bool = True,
        max_features: int | None = None,
        rate: float | None = None,
        selection: str = "relevance",
        random_word: int = 0,
    ):
        self.n0 = num_initial
        self.sets: list[frozenset] = [frozenset([i]) for i in range(num_initial)]
        self.parents: list[tuple[int, int]] = [(-1, -1)] * num_initial
        self.ids: dict[frozenset, int] = {s: i for i, s in enumerate(self.sets)}
        # potential feature -> [ψ, Δ, ν, parents, first-seen order]
        self.potentials: dict[frozenset, list] = {}
        self.pool: list[frozenset] = []  # the random selection list (swap-removal)
        self.threshold = threshold
        self.relevance = relevance
        self.sparsify = sparsify
        self.max_features = math.inf if max_features is None else max_features
        self.rate = rate
        self.selection = selection
        self.random_word = random_word
        self.calls = 0
        self.draws = 0
        self.seen = 0

    @property
    def num_features(self) -> int:
        return len(self.sets)

    def relevance_of(self, stats: list) -> float:
        psi, delta, count = stats[0], stats[1], stats[2]
        if self.relevance == "ifdd":
            return psi  # Eq. 4.2
        if self.relevance == "ifdd_plus":
            return abs(delta) / math.sqrt(count)  # Eq. 4.3, magnitude
        return delta / math.sqrt(count)  # Alg 21 as printed

    # Algorithm 19
    def activate(self, initial) -> list[int]:
        active = frozenset(int(i) for i in initial)
        within = [f for f, s in enumerate(self.sets) if s <= active]
        if not self.sparsify:
            return sorted(within)
        remaining = set(active)
        phi = []
        for f in sorted(within, key=lambda f: (-len(self.sets[f]), -f)):
            if not remaining:
                break
            if self.sets[f] <= remaining:
                phi.append(f)
                remaining -= self.sets[f]
        return sorted(phi)

    def _add(self, union: frozenset) -> None:
        stats = self.potentials.pop(union)
        self.ids[union] = len(self.sets)
        self.sets.append(union)
        self.parents.append(stats[3])

    # Algorithms 20 and 21
    def discover(self, active, td_error: float) -> list[tuple[int, int]]:
        before = self.num_features
        active = [int(f) for f in active]
        for i, g in enumerate(active):
            for h in active[i + 1 :]:
                union = self.sets[g] | self.sets[h]
                if union in (self.sets[g], self.sets[h]) or union in self.ids:
                    continue
                if union not in self.potentials:
                    self.potentials[union] = [0.0, 0.0, 0.0, None, self.seen]
                    self.seen += 1
                    self.pool.append(union)
                stats = self.potentials[union]
                stats[0] += abs(td_error)
                stats[1] += td_error
                stats[2] += 1.0
                stats[3] = (g, h)
                if (
                    self.rate is None
                    and self.relevance_of(stats) > self.threshold
                    and self.num_features < self.max_features
                ):
                    self._add(union)
        self.calls += 1
        if self.rate is not None:
            target = min(self.n0 + math.floor(math.sqrt(self.rate * self.calls)), self.max_features)
            while self.num_features < target and self.potentials:
                if self.selection == "random":
                    pick = random_index(self.random_word, self.draws, len(self.pool))
                    self.draws += 1
                    union = self.pool[pick]
                    self.pool[pick] = self.pool[-1]
                    self.pool.pop()
                else:
                    union = max(
                        self.potentials,
                        key=lambda s: (
                            self.relevance_of(self.potentials[s]),
                            -self.potentials[s][4],
                        ),
                    )
                self._add(union)
        return self.parents[before:]

    def potential_features(self) -> tuple[list[frozenset], list[float]]:
        """Potential features in first-seen order, with their relevances."""
        items = sorted(self.potentials.items(), key=lambda item: item[1][4])
        return [s for s, _ in items], [self.relevance_of(stats) for _, stats in items]


class FlagFeatures(Representation):
    """Binary base features for tests: the state is a 0/1 vector; φ⁰(s) = indices of the ones.

    A fake for the tests (Section 3.2.2's indices of the initial feature function).
    """

    def __init__(self, *, num_flags: int = 21):
        self.num_flags = num_flags

    def setup(self, spec: DomainSpec, seed) -> FlagFeatures:
        self.spec_ = spec
        self.num_features_ = self.num_flags
        self.is_set_up_ = True
        return self

    def active_features(self, state) -> np.ndarray:
        return np.flatnonzero(np.asarray(state) > 0.5).astype(np.int64)


def flags_spec(num_flags: int) -> DomainSpec:
    return DomainSpec(
        name="flags",
        low=np.zeros(num_flags),
        high=np.ones(num_flags),
        is_discrete=np.ones(num_flags, dtype=bool),
        num_actions=1,
        discount=0.9,
        max_episode_steps=10,
    )


def flags(num_flags: int, active) -> np.ndarray:
    state = np.zeros(num_flags)
    state[list(active)] = 1.0
    return state
