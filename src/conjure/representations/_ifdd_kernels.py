"""Numba kernels of online iFDD (Geramifard 2012, Algorithms 19-21, Eq. 4.6).

A conjunction is identified by its SET of initial features. Its key is the XOR of one random
64-bit word per initial feature (kept as int64), so a set's key costs one XOR per member; a
flat open-addressing table (linear probing, capacity a power of two, load at most 1/2) maps a
key to a *node*, and every hit is confirmed against the node's stored sorted index list, so key
collisions are harmless. Nodes are the conjunctions of size >= 2 ever seen as a pair's union:
potential features (``node_feature == -1``) and discovered ones (``node_feature`` = the
feature id). Index lists live in one int64 ``pool``.

Arrays (all preallocated by the Python class, which grows them when a kernel returns -1):

- ``words[i]``: the key word of initial feature i.
- ``feat_start[f], feat_len[f]``: feature f's initial set in ``pool``; ``feat_parents[f]``
  its two parents (-1 for initial features).
- ``node_key, node_start, node_len, node_feature, node_parents (n, 2)``; ``node_stats (n, 3)``
  holds ψ = Σ|δ| (Eq. 4.2), Δ = Σδ and ν = count (Eq. 4.3); ``node_slot`` is the node's
  position in ``heap`` (fixed-rate modes) or -1.
- ``heap``: a max-heap of potential nodes by (relevance, then lower node id) for fixed-rate
  iFDD, or an unordered list (swap-remove) for random expansion.
- ``ints``/``floats``: counters and settings, indexed by the ``I_*``/``F_*`` constants.
- The activation cache (``ctable``, ``centry``, ``cpool``) maps an initial active set to its
  sparsified φ̇ together with the feature count it was computed at.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["activate", "discover", "rebuild_table", "relevance_of"]

# ints layout
I_NUM_FEATURES = 0
I_NUM_INITIAL = 1
I_NUM_NODES = 2
I_POOL_USED = 3
I_NUM_CALLS = 4
I_NUM_DRAWS = 5
I_HEAP_SIZE = 6
I_RELEVANCE = 7
I_SELECTION = 8
I_MAX_FEATURES = 9
I_RANDOM_WORD = 10
I_SPARSIFY = 11
I_CACHE_ENTRIES = 12
I_CACHE_POOL_USED = 13
NUM_INTS = 16
# floats layout
F_THRESHOLD = 0
F_RATE = 1
NUM_FLOATS = 2

RELEVANCE_IFDD = 0
RELEVANCE_IFDD_PLUS = 1
RELEVANCE_IFDD_PLUS_SIGNED = 2
SELECT_THRESHOLD = 0
SELECT_RATE_RELEVANCE = 1
SELECT_RATE_RANDOM = 2

# activation cache entry columns
C_KEY = 0
C_A_START = 1
C_A_LEN = 2
C_PHI_START = 3
C_PHI_LEN = 4
C_CHECKED = 5
NUM_C = 6
#: a stale cache entry is patched (instead of recomputed) if at most this many features were
#: discovered since it was computed and none of them lies within its initial set
PATCH_LIMIT = 32


# ---------------------------------------------------------------------------------------------
# sets and the node table


@njit(cache=True)
def _union(pool, sa, la, sb, lb, words, buf):
    """Merge two sorted index lists into ``buf``; return (length, XOR key)."""
    i = 0
    j = 0
    m = 0
    key = 0
    while i < la and j < lb:
        x = pool[sa + i]
        y = pool[sb + j]
        if x < y:
            buf[m] = x
            i += 1
        elif y < x:
            buf[m] = y
            j += 1
        else:
            buf[m] = x
            i += 1
            j += 1
        key ^= words[buf[m]]
        m += 1
    while i < la:
        buf[m] = pool[sa + i]
        key ^= words[buf[m]]
        i += 1
        m += 1
    while j < lb:
        buf[m] = pool[sb + j]
        key ^= words[buf[m]]
        j += 1
        m += 1
    return m, key


@njit(cache=True)
def _find_node(table, key, buf, m, node_key, node_start, node_len, pool):
    """Return (node or -1, slot) for the set ``buf[:m]`` with key ``key``."""
    mask = table.shape[0] - 1
    slot = key & mask
    while True:
        node = table[slot]
        if node == -1:
            return -1, slot
        if node_key[node] == key and node_len[node] == m:
            start = node_start[node]
            same = True
            for t in range(m):
                if pool[start + t] != buf[t]:
                    same = False
                    break
            if same:
                return node, slot
        slot = (slot + 1) & mask


@njit(cache=True)
def rebuild_table(table, node_key, num_nodes):
    """Re-insert nodes ``0 .. num_nodes - 1`` into the empty (all -1) ``table``."""
    mask = table.shape[0] - 1
    for node in range(num_nodes):
        slot = node_key[node] & mask
        while table[slot] != -1:
            slot = (slot + 1) & mask
        table[slot] = node


@njit(cache=True)
def relevance_of(stats, kind):
    """ψ of a potential feature: Eq. 4.2 (Σ|δ|), or Eq. 4.3 as |Δ|/√ν or Δ/√ν."""
    if kind == RELEVANCE_IFDD:
        return stats[0]
    if kind == RELEVANCE_IFDD_PLUS:
        return abs(stats[1]) / np.sqrt(stats[2])
    return stats[1] / np.sqrt(stats[2])


# ---------------------------------------------------------------------------------------------
# the fixed-rate pool: an indexed max-heap (relevance, then lower node id) or a plain list


@njit(cache=True)
def _before(a, b, node_stats, kind):
    ra = relevance_of(node_stats[a], kind)
    rb = relevance_of(node_stats[b], kind)
    return ra > rb or (ra == rb and a < b)


@njit(cache=True)
def _sift_up(heap, node_slot, pos, node_stats, kind):
    node = heap[pos]
    while pos > 0:
        parent = (pos - 1) // 2
        other = heap[parent]
        if not _before(node, other, node_stats, kind):
            break
        heap[pos] = other
        node_slot[other] = pos
        pos = parent
    heap[pos] = node
    node_slot[node] = pos


@njit(cache=True)
def _sift_down(heap, node_slot, pos, size, node_stats, kind):
    node = heap[pos]
    while True:
        child = 2 * pos + 1
        if child >= size:
            break
        if child + 1 < size and _before(heap[child + 1], heap[child], node_stats, kind):
            child += 1
        other = heap[child]
        if not _before(other, node, node_stats, kind):
            break
        heap[pos] = other
        node_slot[other] = pos
        pos = child
    heap[pos] = node
    node_slot[node] = pos


@njit(cache=True)
def _pool_remove(heap, node_slot, node, ints, node_stats, kind, is_heap):
    pos = node_slot[node]
    last = ints[I_HEAP_SIZE] - 1
    ints[I_HEAP_SIZE] = last
    node_slot[node] = -1
    if pos == last:
        return
    moved = heap[last]
    heap[pos] = moved
    node_slot[moved] = pos
    if is_heap:
        _sift_up(heap, node_slot, pos, node_stats, kind)
        _sift_down(heap, node_slot, node_slot[moved], last, node_stats, kind)


@njit(cache=True)
def _splitmix64(x):
    z = x + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def random_index(random_word, draw, size):
    """The ``draw``-th uniform index in [0, size) of the stream ``random_word`` (counter-based)."""
    z = _splitmix64(np.uint64(random_word) + np.uint64(draw) * np.uint64(0xD1B54A32D192ED03))
    u = np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return int(u * size)


# ---------------------------------------------------------------------------------------------
# Algorithms 20 and 21 (and the fixed-rate rule of Eq. 4.6)


@njit(cache=True)
def _make_feature(node, ints, node_feature, node_start, node_len, node_parents, feat_start,
                  feat_len, feat_parents):  # fmt: skip
    f = ints[I_NUM_FEATURES]
    node_feature[node] = f
    feat_start[f] = node_start[node]
    feat_len[f] = node_len[node]
    feat_parents[f, 0] = node_parents[node, 0]
    feat_parents[f, 1] = node_parents[node, 1]
    ints[I_NUM_FEATURES] = f + 1


@njit(cache=True)
def discover(active, td_error, words, pool, feat_start, feat_len, feat_parents, node_key,
             node_start, node_len, node_feature, node_parents, node_stats, node_slot, table,
             heap, ints, floats):  # fmt: skip
    """Update the relevances of every co-active pair and discover features; Alg 20/21.

    Returns the number of features added (their ids follow the previous count, their parents
    are in ``feat_parents``), or -1 before changing anything if an array is too small.
    """
    k = active.shape[0]
    num_pairs = k * (k - 1) // 2
    total = 0
    for i in range(k):
        total += feat_len[active[i]]
    num_nodes = ints[I_NUM_NODES]
    if (
        ints[I_POOL_USED] + (k - 1) * total > pool.shape[0]
        or num_nodes + num_pairs > node_key.shape[0]
        or 2 * (num_nodes + num_pairs) > table.shape[0]
    ):
        return -1
    before = ints[I_NUM_FEATURES]
    kind = ints[I_RELEVANCE]
    selection = ints[I_SELECTION]
    max_features = ints[I_MAX_FEATURES]
    threshold = floats[F_THRESHOLD]
    magnitude = abs(td_error)
    buf = np.empty(max(total, 1), dtype=np.int64)
    for i in range(k):  # line 1: every pair (g, h) of active features
        g = active[i]
        for j in range(i + 1, k):
            h = active[j]
            m, key = _union(pool, feat_start[g], feat_len[g], feat_start[h], feat_len[h],
                            words, buf)  # fmt: skip
            if m == feat_len[g] or m == feat_len[h]:
                continue  # f = g ∪ h is g or h itself (only without sparsification)
            node, slot = _find_node(table, key, buf, m, node_key, node_start, node_len, pool)
            if node >= 0 and node_feature[node] >= 0:
                continue  # line 3: f is already a feature
            if node < 0:  # a new potential feature
                node = ints[I_NUM_NODES]
                ints[I_NUM_NODES] = node + 1
                start = ints[I_POOL_USED]
                pool[start : start + m] = buf[:m]
                ints[I_POOL_USED] = start + m
                node_key[node] = key
                node_start[node] = start
                node_len[node] = m
                node_feature[node] = -1
                node_stats[node, 0] = 0.0
                node_stats[node, 1] = 0.0
                node_stats[node, 2] = 0.0
                node_slot[node] = -1
                table[slot] = node
                if selection != SELECT_THRESHOLD:
                    size = ints[I_HEAP_SIZE]
                    heap[size] = node
                    node_slot[node] = size
                    ints[I_HEAP_SIZE] = size + 1
            node_stats[node, 0] += magnitude  # Alg 20 line 4: ψ_f += |δ|
            node_stats[node, 1] += td_error  # Alg 21 line 4: Δ_f += δ
            node_stats[node, 2] += 1.0  # Alg 21 line 5: ν_f += 1
            node_parents[node, 0] = g
            node_parents[node, 1] = h
            if selection == SELECT_THRESHOLD:
                # Alg 20 line 5 / Alg 21 line 7: discover when ψ_f > ξ
                if (
                    relevance_of(node_stats[node], kind) > threshold
                    and ints[I_NUM_FEATURES] < max_features
                ):
                    _make_feature(node, ints, node_feature, node_start, node_len, node_parents,
                                  feat_start, feat_len, feat_parents)  # fmt: skip
            elif selection == SELECT_RATE_RELEVANCE:
                pos = node_slot[node]
                _sift_up(heap, node_slot, pos, node_stats, kind)
                _sift_down(heap, node_slot, node_slot[node], ints[I_HEAP_SIZE], node_stats, kind)
    ints[I_NUM_CALLS] += 1
    if selection != SELECT_THRESHOLD:
        # Eq. 4.6: keep n_t = n_0 + floor(sqrt(C t)) features
        target = ints[I_NUM_INITIAL] + int(np.floor(np.sqrt(floats[F_RATE] * ints[I_NUM_CALLS])))
        target = min(target, max_features)
        is_heap = selection == SELECT_RATE_RELEVANCE
        while ints[I_NUM_FEATURES] < target and ints[I_HEAP_SIZE] > 0:
            if is_heap:
                node = heap[0]
            else:
                pick = random_index(ints[I_RANDOM_WORD], ints[I_NUM_DRAWS], ints[I_HEAP_SIZE])
                ints[I_NUM_DRAWS] += 1
                node = heap[pick]
            _pool_remove(heap, node_slot, node, ints, node_stats, kind, is_heap)
            _make_feature(node, ints, node_feature, node_start, node_len, node_parents,
                          feat_start, feat_len, feat_parents)  # fmt: skip
    return ints[I_NUM_FEATURES] - before


# ---------------------------------------------------------------------------------------------
# Algorithm 19: the sparsified φ̇(s), with a cache per initial active set


@njit(cache=True)
def _is_subset(pool, start, length, initial):
    """Whether the sorted list ``pool[start:start+length]`` is a subset of sorted ``initial``."""
    j = 0
    k = initial.shape[0]
    for t in range(length):
        x = pool[start + t]
        while j < k and initial[j] < x:
            j += 1
        if j == k or initial[j] != x:
            return False
        j += 1
    return True


@njit(cache=True)
def _features_within(initial, words, pool, feat_start, feat_len, node_key, node_start,
                     node_len, node_feature, table):  # fmt: skip
    """Every feature whose initial set lies within ``initial`` (the closure under unions).

    Each discovered feature is the union of two features (its parents), both within its set,
    so unions of pairs of found features, starting from the initial features, reach them all.
    """
    k = initial.shape[0]
    found = np.empty(max(2 * k, 16), dtype=np.int64)
    found[:k] = initial
    m = k
    buf = np.empty(max(k, 1), dtype=np.int64)
    x = 1
    while x < m:
        fx = found[x]
        for y in range(x):
            fy = found[y]
            length, key = _union(pool, feat_start[fx], feat_len[fx], feat_start[fy],
                                 feat_len[fy], words, buf)  # fmt: skip
            if length == feat_len[fx] or length == feat_len[fy]:
                continue
            node, _ = _find_node(table, key, buf, length, node_key, node_start, node_len, pool)
            if node < 0:
                continue
            f = node_feature[node]
            if f < 0:
                continue
            seen = False
            for z in range(k, m):
                if found[z] == f:
                    seen = True
                    break
            if seen:
                continue
            if m == found.shape[0]:
                grown = np.empty(2 * m, dtype=np.int64)
                grown[:m] = found
                found = grown
            found[m] = f
            m += 1
        x += 1
    return found[:m]


@njit(cache=True)
def _cover(initial, members, pool, feat_start, feat_len):
    """Greedy covering (Alg 19 lines 3-8): largest first, ties to the latest discovered."""
    k = initial.shape[0]
    m = members.shape[0]
    order_key = np.empty(m, dtype=np.int64)
    for i in range(m):
        order_key[i] = -(feat_len[members[i]] * (1 << 40) + members[i])
    order = np.argsort(order_key, kind="mergesort")
    covered = np.zeros(k, dtype=np.bool_)
    remaining = k
    out = np.empty(k, dtype=np.int64)
    count = 0
    for r in range(m):
        f = members[order[r]]
        start = feat_start[f]
        length = feat_len[f]
        free = True
        for t in range(length):
            if covered[np.searchsorted(initial, pool[start + t])]:
                free = False
                break
        if not free:
            continue
        for t in range(length):
            covered[np.searchsorted(initial, pool[start + t])] = True
        out[count] = f
        count += 1
        remaining -= length
        if remaining == 0:
            break
    return np.sort(out[:count])


@njit(cache=True)
def _compute(initial, words, pool, feat_start, feat_len, node_key, node_start, node_len,
             node_feature, table, sparsify):  # fmt: skip
    members = _features_within(initial, words, pool, feat_start, feat_len, node_key,
                               node_start, node_len, node_feature, table)  # fmt: skip
    if not sparsify:
        return np.sort(members)
    return _cover(initial, members, pool, feat_start, feat_len)


@njit(cache=True)
def activate(initial, words, pool, feat_start, feat_len, node_key, node_start, node_len,
             node_feature, table, ints, ctable, centry, cpool):  # fmt: skip
    """φ̇(s) from the sorted initial active features φ⁰(s) (Algorithm 19), cached per set."""
    n = ints[I_NUM_FEATURES]
    if n == ints[I_NUM_INITIAL]:
        return initial.copy()  # nothing discovered: φ̇ = φ⁰
    k = initial.shape[0]
    key = 0
    for i in range(k):
        key ^= words[initial[i]]
    mask = ctable.shape[0] - 1
    slot = key & mask
    entry = -1
    while True:
        e = ctable[slot]
        if e == -1:
            break
        if centry[e, C_KEY] == key and centry[e, C_A_LEN] == k:
            start = centry[e, C_A_START]
            same = True
            for t in range(k):
                if cpool[start + t] != initial[t]:
                    same = False
                    break
            if same:
                entry = e
                break
        slot = (slot + 1) & mask
    if entry >= 0:
        checked = centry[entry, C_CHECKED]
        is_valid = checked == n
        if not is_valid and n - checked <= PATCH_LIMIT:
            is_valid = True
            for f in range(checked, n):
                if _is_subset(pool, feat_start[f], feat_len[f], initial):
                    is_valid = False
                    break
        if is_valid:
            centry[entry, C_CHECKED] = n
            start = centry[entry, C_PHI_START]
            return cpool[start : start + centry[entry, C_PHI_LEN]].copy()
    sparsify = ints[I_SPARSIFY] != 0
    phi = _compute(initial, words, pool, feat_start, feat_len, node_key, node_start, node_len,
                   node_feature, table, sparsify)  # fmt: skip
    size = phi.shape[0]
    need = size + (0 if entry >= 0 else k)
    if (
        ints[I_CACHE_POOL_USED] + need > cpool.shape[0]
        or (entry < 0 and 2 * (ints[I_CACHE_ENTRIES] + 1) > ctable.shape[0])
        or (entry < 0 and ints[I_CACHE_ENTRIES] == centry.shape[0])
    ):
        if size + k > cpool.shape[0]:
            return phi  # too large to cache at all
        ctable[:] = -1  # full: forget every cached set
        ints[I_CACHE_ENTRIES] = 0
        ints[I_CACHE_POOL_USED] = 0
        entry = -1
        slot = key & mask
    used = ints[I_CACHE_POOL_USED]
    if entry < 0:
        entry = ints[I_CACHE_ENTRIES]
        ints[I_CACHE_ENTRIES] = entry + 1
        ctable[slot] = entry
        centry[entry, C_KEY] = key
        centry[entry, C_A_START] = used
        centry[entry, C_A_LEN] = k
        cpool[used : used + k] = initial
        used += k
    centry[entry, C_PHI_START] = used
    centry[entry, C_PHI_LEN] = size
    centry[entry, C_CHECKED] = n
    cpool[used : used + size] = phi
    ints[I_CACHE_POOL_USED] = used + size
    return phi
