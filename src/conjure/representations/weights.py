"""Weights of newly discovered features: θ_f = θ_g + θ_h (Geramifard 2012, Section 4.1.1)."""

from __future__ import annotations

import numpy as np
from numba import njit

from conjure.core.errors import InvalidParameterError
from conjure.core.interfaces import Expansion

__all__ = [
    "append_rows",
    "expansion_parents",
    "grow_weights",
    "initial_weights",
    "parent_sum_row",
    "with_room",
]


def initial_weights(shape: tuple[int, ...], value: float) -> np.ndarray:
    """θ of ``shape`` with every entry ``value``, float64.

    Zero-initialised θ comes from ``np.zeros``, whose pages the operating system maps only
    when first written, so a table indexed lazily (`HashedTabular`: rows in order of first
    visit) costs memory for the rows a run reaches, not for its capacity; ``np.full`` would
    write, and so map, every page.
    """
    if value == 0.0:
        return np.zeros(shape)
    return np.full(shape, float(value))


def append_rows(array: np.ndarray, num_new: int, fill: float = 0.0) -> np.ndarray:
    """Return ``array`` with ``num_new`` rows of ``fill`` appended, in amortised Θ(row) time.

    The result is a leading-rows view of a buffer with spare capacity (doubled when full), so
    adding features one at a time costs Θ(1) rows each, not a copy of the whole array: the
    thesis's requirement that online iFDD's per-step cost not grow with the number of features
    (Section 4.1.3). The result may share memory with ``array``: always use the returned array.

    Examples
    --------
    >>> import numpy as np
    >>> grown = append_rows(np.ones((2, 3)), 1, fill=-1.0)
    >>> grown.tolist()
    [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, -1.0, -1.0]]
    >>> append_rows(grown, 1).base is grown.base  # spare capacity is reused
    True
    """
    num_rows = array.shape[0]
    buffer = array.base if _is_leading_view(array) else None
    if buffer is None or buffer.shape[0] < num_rows + num_new:
        capacity = max(2 * num_rows, num_rows + num_new, 16)
        buffer = np.empty((capacity, *array.shape[1:]), dtype=array.dtype)
        buffer[:num_rows] = array
    buffer[num_rows : num_rows + num_new] = fill
    return buffer[: num_rows + num_new]


def with_room(array: np.ndarray, rows: int) -> np.ndarray:
    """A C-contiguous array of at least ``rows`` rows whose leading rows are ``array``.

    ``array`` itself when it is contiguous and has the rows, else the buffer it leads (see
    `append_rows`) when that has the rows, else a new buffer (doubling). The compiled loop
    (`conjure.compiled`) writes new features' rows there; the learner then keeps the leading
    rows in use, which `append_rows` goes on growing in place.
    """
    if array.shape[0] >= rows and array.flags.c_contiguous:
        return array
    if _is_leading_view(array) and array.base.shape[0] >= rows:
        return array.base
    buffer = np.empty((max(rows, 2 * array.shape[0]), *array.shape[1:]), dtype=array.dtype)
    buffer[: array.shape[0]] = array
    return buffer


def _is_leading_view(array: np.ndarray) -> bool:
    base = array.base
    return (
        isinstance(base, np.ndarray)
        and base.base is None
        and base.flags.c_contiguous
        and base.shape[1:] == array.shape[1:]
        and base.dtype == array.dtype
        and base.__array_interface__["data"][0] == array.__array_interface__["data"][0]
    )


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
        Row ``first_new + i`` equals ``weights[g_i] + weights[h_i]``; a parent of −1 adds
        nothing (a split tile copies its one parent, a fresh prototype starts at zero). The
        result comes from `append_rows`, so it may share memory with ``weights``.

    Raises
    ------
    InvalidParameterError
        If ``expansion.first_new`` is not the current row count, or a parent is not an
        existing feature or −1.

    Notes
    -----
    - Symbols: θ ``weights``; (g, h) a row of ``expansion.parents``.
    - Choice: a new feature may have a parent added earlier in the same expansion (rows are
      filled in order), so parents must lie in ``[0, first_new + i)`` (or be −1).

    Complexity
    ----------
    Amortised Θ(|A|) per new feature (see `append_rows`), Θ(1) when nothing is added.

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
    parents = expansion_parents(expansion, num_rows)
    num_new = parents.shape[0]
    if num_new == 0:
        return weights
    grown = append_rows(weights, num_new)
    as_table = grown.reshape(grown.shape[0], -1)  # a view: rows stay rows
    for i in range(num_new):
        parent_sum_row(as_table, parents[i, 0], parents[i, 1], num_rows + i)
    return grown


def expansion_parents(expansion: Expansion, num_rows: int) -> np.ndarray:
    """The (g, h) of each new feature (int64, shape (num_new, 2)), checked against the rows.

    Raises `InvalidParameterError` if ``expansion.first_new`` is not ``num_rows`` (the
    weights were not grown after every ``discover``) or a parent is neither −1 nor an existing
    feature (row i's parents in ``[0, num_rows + i)``).
    """
    if expansion.first_new != num_rows:
        raise InvalidParameterError(
            f"grow_weights: the expansion numbers its new features from "
            f"{expansion.first_new}, but the weights have {num_rows} rows; were the weights "
            f"grown after every discover() call?"
        )
    num_new = expansion.num_new
    parents = np.asarray(expansion.parents, dtype=np.int64).reshape(num_new, 2)
    limits = num_rows + np.arange(num_new)[:, None]
    if np.any(parents < -1) or np.any(parents >= limits):
        raise InvalidParameterError(
            f"grow_weights: parents must be existing features (row i in [0, {num_rows} + i)) "
            f"or -1; got {parents.tolist()}."
        )
    return parents


@njit(cache=True)
def parent_sum_row(weights: np.ndarray, g: int, h: int, f: int) -> None:
    """Row f ← (0 + θ_g) + θ_h, a parent of −1 adding nothing (Section 4.1.1).

    The one kernel of new features' weights: `grow_weights` and the learners' growth kernel
    (`conjure.agents.compiled_agent.grow_learner_rows`) both call it.
    """
    for a in range(weights.shape[1]):
        weights[f, a] = 0.0
        if g >= 0:
            weights[f, a] += weights[g, a]
        if h >= 0:
            weights[f, a] += weights[h, a]
