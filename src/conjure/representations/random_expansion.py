"""Random expansion at a fixed rate: the baseline of online iFDD (Geramifard 2012, Fig. 4-7)."""

from __future__ import annotations

from conjure.core.interfaces import Representation
from conjure.representations.online_ifdd import OnlineIFDD

__all__ = ["RandomExpansion"]


class RandomExpansion(OnlineIFDD):
    """Conjunctions added at the rate of Eq. 4.6, chosen uniformly among potential features.

    Geramifard (2012), Section 4.1.4, "Online iFDD vs. Random Expansion" (Fig. 4-7): the
    feature count follows n_t = n₀ + √(C t) (Eq. 4.6) exactly as for fixed-rate `OnlineIFDD`,
    but each new feature is drawn uniformly at random from the current potential features
    (the unions of pairs of co-active features seen so far) instead of by relevance. It is
    `OnlineIFDD` with ``expansion="random"`` and a rate by default, under the name the
    thesis and the example configs use: every parameter is `OnlineIFDD`'s, and the sparsified
    φ̇ (Algorithm 19) and the weights rule θ_f = θ_g + θ_h (Section 4.1.1) are its too.

    Parameters
    ----------
    base : Representation
        The initial binary features φ⁰; ids ``0 .. n₀ - 1`` as in `OnlineIFDD`.
    discovery_threshold : float, default 1.0
        ξ of `OnlineIFDD`; unused at a fixed rate.
    relevance : {"ifdd", "ifdd_plus", "ifdd_plus_signed"}, default "ifdd"
        The ψ tracked for inspection (`relevances_`); it does not choose features.
    sparsify : bool, default True
        Whether φ̇ is sparsified (Algorithm 19).
    max_features : int or None, default None
        Cap on the total number of features, the n₀ initial ones of ``base`` plus the added
        ones, in [n₀, inf) (a smaller cap raises at setup); ``None``: no cap.
    discovery_rate : float, default 0.2
        C in (0, inf) of Eq. 4.6 (the thesis used 0.2, 0.4, 2 and 0.004 on its four domains).
    expansion : {"relevance", "random"}, default "random"
        As `OnlineIFDD`'s; "random" is this baseline.

    Attributes
    ----------
    num_features_ : int
        n_t.
    num_initial_features_ : int
        n₀.
    parents_ : ndarray of int64, shape (num_features_, 2)
        Parents (g, h) of each feature; (−1, −1) for initial ones.

    Notes
    -----
    Symbols: C ``discovery_rate``, t the number of `discover` calls, n_t ``num_features_``.

    - Choice: n_t = n₀ + ⌊√(C t)⌋, as for fixed-rate `OnlineIFDD`; the draws are those of
      `OnlineIFDD`'s ``expansion="random"`` (counter-based, from the setup seed).

    Complexity
    ----------
    Θ(k_t² k₀) per `discover` call (Θ(1) per random pick), as `OnlineIFDD`.

    Examples
    --------
    >>> from conjure.core import DomainSpec
    >>> from conjure.representations import IndependentDiscretization
    >>> spec = DomainSpec(name="box", low=[0.0, 0.0], high=[1.0, 1.0], is_discrete=[False, False],
    ...                   num_actions=2, discount=0.9, max_episode_steps=10)
    >>> base = IndependentDiscretization(num_buckets=2)
    >>> rep = RandomExpansion(base=base, discovery_rate=1.0).setup(spec, seed=0)
    >>> expansion = rep.discover(rep.active_features([0.9, 0.9]), td_error=0.0)
    >>> rep.num_features_  # n_1 = 4 + floor(sqrt(1 * 1))
    5
    """

    def __init__(
        self,
        *,
        base: Representation,
        discovery_threshold: float = 1.0,
        relevance: str = "ifdd",
        sparsify: bool = True,
        max_features: int | None = None,
        discovery_rate: float | None = 0.2,
        expansion: str = "random",
    ):
        super().__init__(
            base=base,
            discovery_threshold=discovery_threshold,
            relevance=relevance,
            sparsify=sparsify,
            max_features=max_features,
            discovery_rate=discovery_rate,
            expansion=expansion,
        )
