"""What V-API and Q-API share (Algorithms 3 and 4): their parameters and the weighted solve."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from conjure.core.interfaces import Representation
from conjure.core.linalg import solve_regularized
from conjure.core.params import InstanceOf, Interval, Options
from conjure.planners.base import Planner


class ModelAPI(Planner):
    """Base of `VAPI` and `QAPI` (Algorithms 3 and 4): approximate π's values on an exact model.

    Parameters
    ----------
    representation : Representation or None, default None
        φ(s); ``None`` means `Tabular`.
    evaluation : {"lstd", "brm"}, default "lstd"
        Projected (LSTD) or residual (BRM) evaluation.
    epsilon : float, default 0.1
        The ε of the π^ε that weights the states, in [0, 1].
    weighting : {"uniform", "steady_state"}, default "uniform"
        How states are weighted.
    regularization : float, default 1e-10
        λ ≥ 0 added to A's diagonal.
    max_iterations : int, default 100
        Cap on policy improvements, in [1, inf).
    seed : int, default 0
        Seed of the random initial policy and the representation.
    """

    parameter_constraints = {
        "representation": InstanceOf((Representation, type(None)), "a Representation or None"),
        "evaluation": Options(("lstd", "brm")),
        "epsilon": Interval(float, 0.0, 1.0),
        "weighting": Options(("steady_state", "uniform")),
        "regularization": Interval(float, 0.0, None),
        "max_iterations": Interval(int, 1, None),
        "seed": Interval(int, 0, None),
    }

    def __init__(
        self,
        *,
        representation: Representation | None = None,
        evaluation: str = "lstd",
        epsilon: float = 0.1,
        weighting: str = "uniform",
        regularization: float = 1e-10,
        max_iterations: int = 100,
        seed: int = 0,
    ):
        self.representation = representation
        self.evaluation = evaluation
        self.epsilon = epsilon
        self.weighting = weighting
        self.regularization = regularization
        self.max_iterations = max_iterations
        self.seed = seed

    def _solve(
        self,
        features: sp.csr_matrix,
        next_features: sp.csr_matrix,
        rewards: np.ndarray,
        weighting: np.ndarray,
        discount: float,
    ) -> np.ndarray:
        """θ = A⁻¹b with A = LᵀD(Φ − γPΦ), b = LᵀDR, L = Φ (LSTD) or Φ − γPΦ (BRM), regularised.

        Eqs. 2.17 and 2.15 for V (Algorithm 3), Eqs. 2.20 and 2.19 for Q (Algorithm 4).
        """
        residual = features - discount * next_features  # Φ − γPΦ
        left = sp.csr_matrix((residual if self.evaluation == "brm" else features).T)
        left = left @ sp.diags(weighting)
        return solve_regularized(left @ residual, left @ rewards, self.regularization)
