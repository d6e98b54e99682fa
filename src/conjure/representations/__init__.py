"""Representations φ(s) (Geramifard 2012, Sections 2.4, 3.1, 4.1 and 4.3) and the weight rule.

Binary, sparse representations return the sorted indices of their active features
(`active_features`); the dense `RBF` returns every feature value (`feature_values`).
Adaptive representations add features in `discover`; `grow_weights` applies
θ_f = θ_g + θ_h (Section 4.1.1) to the learner's weights.
"""

from conjure.representations.adaptive_tile_coding import AdaptiveTileCoding
from conjure.representations.arifdd import ARiFDD
from conjure.representations.hashed_tabular import HashedTabular
from conjure.representations.independent_discretization import IndependentDiscretization
from conjure.representations.indicators import BinaryIndicators
from conjure.representations.online_ifdd import OnlineIFDD
from conjure.representations.random_expansion import RandomExpansion
from conjure.representations.rbf import RBF
from conjure.representations.sparse_distributed_memory import SparseDistributedMemory
from conjure.representations.tabular import Tabular
from conjure.representations.tile_coding import TileCoding
from conjure.representations.weights import append_rows, grow_weights

__all__ = [
    "RBF",
    "ARiFDD",
    "AdaptiveTileCoding",
    "BinaryIndicators",
    "HashedTabular",
    "IndependentDiscretization",
    "OnlineIFDD",
    "RandomExpansion",
    "SparseDistributedMemory",
    "Tabular",
    "TileCoding",
    "append_rows",
    "grow_weights",
]
