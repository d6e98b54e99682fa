"""Weights of newly discovered features: θ_f = θ_g + θ_h (Geramifard 2012, Section 4.1.1)."""

from __future__ import annotations

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Expansion

__all__ = ["grow_weights"]


def grow_weights(weights: np.ndarray, expansion: Expansion | None) -> np.ndarray:
    """Return ``weights`` with one row per new feature f = g ∪ h set to θ_g + θ_h.

    Geramifard (2012), Section 4.1.1: when online iFDD adds the conjunction f of features g and
    h, it initialises θ_f = θ_g + θ_h, so that by Theorem 3.4.4 the value of no state changes
    at discovery. A representation never owns the weights; learners call this after every
    `discover` (Algorithm 20).

    Parameters
    ----------
    weights : ndarray, shape (n, ...) (usually (n, |A|))
        θ, one row per feature; ``n`` must equal ``expansion.first_new``.
    expansion : Expansion or None
        The features added this step; ``None`` or an empty expansion returns ``weights``.

    Returns
    -------
    ndarray, shape (n + expansion.num_new, ...)
        A new array (the same object if nothing was added) with row ``first_new + i`` equal to
        ``weights[g_i] + weights[h_i]``.

    Raises
    ------
    InvalidParameterError
        If ``expansion.first_new`` is not the current row count, or a parent is not an
        existing feature.

    Notes
    -----
    - Symbols: θ ``weights``; (g, h) a row of ``expansion.parents``.
    - Choice: a new feature may have a parent added earlier in the same expansion (rows are
      filled in order), so parents must lie in ``[0, first_new + i)``.

    Complexity
    ----------
    Θ(n · |A|) when features are added (one copy of θ), Θ(1) otherwise.

    Examples
    --------
    >>> import numpy as np
    >>> from conjure.core import Expansion
    >>> theta = np.array([[1.0, 2.0], [10.0, 20.0]])
    >>> grow_weights(theta, Expansion(first_new=2, parents=np.array([[0, 1]]))).tolist()
    [[1.0, 2.0], [10.0, 20.0], [11.0, 22.0]]
    """
    if expansion is None:
        return weights
    num_rows = weights.shape[0]
    if expansion.first_new != num_rows:
        raise InvalidParameterError(
            f"grow_weights: the expansion numbers its new features from "
            f"{expansion.first_new}, but the weights have {num_rows} rows; were the weights "
            f"grown after every discover() call?"
        )
    num_new = expansion.num_new
    if num_new == 0:
        return weights
    parents = np.asarray(expansion.parents, dtype=np.int64).reshape(num_new, 2)
    limits = num_rows + np.arange(num_new)[:, None]
    if np.any(parents < 0) or np.any(parents >= limits):
        raise InvalidParameterError(
            f"grow_weights: parents must be existing features (row i in [0, {num_rows} + i)); "
            f"got {parents.tolist()}."
        )
    grown = np.empty((num_rows + num_new, *weights.shape[1:]), dtype=weights.dtype)
    grown[:num_rows] = weights
    if np.all(parents < num_rows):
        grown[num_rows:] = weights[parents[:, 0]] + weights[parents[:, 1]]
    else:
        for i, (g, h) in enumerate(parents):
            grown[num_rows + i] = grown[g] + grown[h]
    return grown
