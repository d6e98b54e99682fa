"""Representations φ(s) (Geramifard 2012, Sections 2.4, 3.1, 4.1 and 4.3) and the weight rule.

Binary, sparse representations return the sorted indices of their active features
(`active_features`); the dense `RBF` returns every feature value (`feature_values`).
Adaptive representations add features in `discover`; `grow_weights` applies
θ_f = θ_g + θ_h (Section 4.1.1) to the learner's weights.
"""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "AdaptiveTileCoding": "adaptive_tile_coding",
    "ARiFDD": "arifdd",
    "HashedTabular": "hashed_tabular",
    "IndependentDiscretization": "independent_discretization",
    "BinaryIndicators": "indicators",
    "OnlineIFDD": "online_ifdd",
    "RandomExpansion": "random_expansion",
    "RBF": "rbf",
    "SparseDistributedMemory": "sparse_distributed_memory",
    "Tabular": "tabular",
    "TileCoding": "tile_coding",
    "append_rows": "weights",
    "grow_weights": "weights",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
