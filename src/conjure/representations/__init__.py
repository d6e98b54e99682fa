"""Representations φ(s) (Geramifard 2012, Sections 2.4, 3.1 and 4.1.4) and the weight rule.

Binary, sparse representations return the sorted indices of their active features
(`active_features`); the dense `RBF` returns every feature value (`feature_values`).
`grow_weights` applies θ_f = θ_g + θ_h (Section 4.1.1) when an adaptive representation adds
features.
"""

from conjure.representations.independent_discretization import IndependentDiscretization
from conjure.representations.rbf import RBF
from conjure.representations.tabular import Tabular
from conjure.representations.tile_coding import TileCoding
from conjure.representations.weights import grow_weights

__all__ = ["RBF", "IndependentDiscretization", "Tabular", "TileCoding", "grow_weights"]
