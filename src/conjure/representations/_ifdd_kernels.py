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
- ``links (capacity, NUM_L)``, ``children (4 capacity + 8, 2)`` and ``pair_table``: the
  parent index of Algorithm 19's activation (derived from ``feat_parents``, never saved;
  `link_children` adds new features). Feature p's children lie in one contiguous block of
  ``children`` rows (child, its other parent), so walking them reads memory in order.
- The activation cache (``centry`` rows, ``cpool`` ring) maps an initial active set to its
  sparsified φ̇ together with the feature count it was computed at.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["activate", "discover", "discover_room", "rebuild_table", "relevance_of"]

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
I_CACHE_WRITTEN = 12
I_LINKED = 13
I_CHILDREN_USED = 14
#: the counters of the activation cache and the child lists: rebuilt on load, never saved
TRANSIENT_INTS = slice(I_CACHE_WRITTEN, I_CHILDREN_USED + 1)
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

# columns of the parent index ``links``: where a feature's block of children starts in
# ``children``, how many it holds and how many rows the block has
L_START = 0
L_COUNT = 1
L_CAPACITY = 2
NUM_L = 3
# activation cache row columns
C_KEY = 0
C_START = 1
C_A_LEN = 2
C_PHI_LEN = 3
C_CHECKED = 4
NUM_C = 5
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
def discover_room(active, feat_len, pool, node_key, table, ints):
    """Σ of the active features' set sizes if `discover` fits in the arrays, else -1."""
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
    return total


@njit(cache=True)
def discover(active, td_error, words, pool, feat_start, feat_len, feat_parents, node_key,
             node_start, node_len, node_feature, node_parents, node_stats, node_slot, table,
             heap, ints, floats):  # fmt: skip
    """Update the relevances of every co-active pair and discover features; Alg 20/21.

    Returns the number of features added (their ids follow the previous count, their parents
    are in ``feat_parents``), or -1 before changing anything if an array is too small.
    """
    total = discover_room(active, feat_len, pool, node_key, table, ints)
    if total < 0:
        return -1
    k = active.shape[0]
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
                for t in range(m):  # a loop: see `conjure.compiled.learning_loop._copy`
                    pool[start + t] = buf[t]
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


@njit(cache=True, inline="always")
def _pair_slot(a, b, mask):
    """The first slot of the unordered parent pair {a, b} in the pair table."""
    lo = np.uint64(min(a, b))
    hi = np.uint64(max(a, b))
    z = lo * np.uint64(0x9E3779B97F4A7C15) ^ hi * np.uint64(0xC2B2AE3D27D4EB4F)
    return np.int64((z ^ (z >> np.uint64(29))) & np.uint64(mask))


@njit(cache=True)
def link_children(feat_len, feat_parents, links, children, pair_table, ints):
    """Index the features discovered since the last call by their parents.

    Feature f = g ∪ h is a row (f, h) in g's block of ``children`` and (f, g) in h's.
    ``pair_table`` (open addressing) finds the feature whose parents are a given pair.
    Features of one initial feature (ARiFDD's split tiles) have no parents to index.
    """
    n = ints[I_NUM_FEATURES]
    mask = pair_table.shape[0] - 1
    for f in range(ints[I_LINKED], n):
        if feat_len[f] < 2:
            continue
        a = min(feat_parents[f, 0], feat_parents[f, 1])
        b = max(feat_parents[f, 0], feat_parents[f, 1])
        _add_child(a, f, b, links, children, ints)
        _add_child(b, f, a, links, children, ints)
        slot = _pair_slot(a, b, mask)
        while pair_table[slot, 0] != -1:
            slot = (slot + 1) & mask
        pair_table[slot, 0] = f
        pair_table[slot, 1] = a
        pair_table[slot, 2] = b
    ints[I_LINKED] = n


@njit(cache=True, inline="always")
def _add_child(parent, child, other, links, children, ints):
    """Append the row (child, other) to parent's block, moving a full block to the end."""
    count = links[parent, L_COUNT]
    if count == links[parent, L_CAPACITY]:
        _move_block(parent, max(4, 2 * count), links, children, ints)
    row = links[parent, L_START] + count
    children[row, 0] = child
    children[row, 1] = other
    links[parent, L_COUNT] = count + 1


@njit(cache=True)
def _move_block(parent, capacity, links, children, ints):
    """Give parent's block ``capacity`` rows at the end of ``children`` (compacting if full).

    The old rows become garbage until `_compact`. ``children`` holds 4 C + 8 rows for C
    features: the live rows are two per feature (at most 2 C) and a block at most doubles
    (at most 2 C more), so after compaction the block always fits.
    """
    if ints[I_CHILDREN_USED] + capacity > children.shape[0]:
        _compact(links, children, ints)
    start = ints[I_CHILDREN_USED]
    old = links[parent, L_START]
    for t in range(links[parent, L_COUNT]):
        children[start + t, 0] = children[old + t, 0]
        children[start + t, 1] = children[old + t, 1]
    links[parent, L_START] = start
    links[parent, L_CAPACITY] = capacity
    ints[I_CHILDREN_USED] = start + capacity


@njit(cache=True)
def _compact(links, children, ints):
    """Pack every block to its live rows, in feature order, dropping the garbage."""
    live = np.empty((ints[I_CHILDREN_USED], 2), dtype=np.int64)
    used = 0
    for p in range(links.shape[0]):
        old = links[p, L_START]
        count = links[p, L_COUNT]
        for t in range(count):
            live[used + t, 0] = children[old + t, 0]
            live[used + t, 1] = children[old + t, 1]
        links[p, L_START] = used
        links[p, L_CAPACITY] = count
        used += count
    for r in range(used):
        children[r, 0] = live[r, 0]
        children[r, 1] = live[r, 1]
    ints[I_CHILDREN_USED] = used


@njit(cache=True, inline="always")
def _pair_child(a, b, pair_table):
    """The feature whose parents are {a, b}, or -1."""
    mask = pair_table.shape[0] - 1
    lo = min(a, b)
    hi = max(a, b)
    slot = _pair_slot(lo, hi, mask)
    while True:
        f = pair_table[slot, 0]
        if f == -1 or (pair_table[slot, 1] == lo and pair_table[slot, 2] == hi):
            return f
        slot = (slot + 1) & mask


@njit(cache=True)
def _features_within(initial, links, children, pair_table):
    """Every feature whose initial set lies within ``initial``, found from the parent index.

    Returns the found features (the initial ones first) and their initial sets as bit sets
    over the positions in ``initial`` (row i is found[i]'s; ``words`` uint64 words a row).
    The found list starts with room for 16 k features and doubles (starting again) if full.
    """
    k = initial.shape[0]
    words = (k + 63) // 64
    capacity = max(16 * k, 64)
    while True:
        found = np.empty(capacity, dtype=np.int64)
        sets = np.zeros((capacity, words), dtype=np.uint64)
        slots = _empty_table(capacity)
        m = _expand(initial, links, children, pair_table, found, sets, slots)
        if m >= 0:
            return found[:m], sets[:m]
        capacity *= 2


@njit(cache=True)
def _expand(initial, links, children, pair_table, found, sets, slots):
    """Fill the found list from ``initial``; return its length, or -1 if it does not fit.

    A discovered feature f = g ∪ h lies within the set exactly when both parents do, so it is
    found when the first of its parents to be expanded, at position x of the found list, is
    expanded with the other already found: either by walking that parent's block of children
    (keeping those whose other parent is found) or by looking up its pairs with the x
    features found before it, whichever is shorter. The cost is at most Θ(m²) for the m
    features found and never depends on n_t; which features are found is looked up in
    ``slots``, a small hash table local to the call, so a walk reads ``children`` in order
    and touches no per-feature memory.

    Choice: the probes of ``slots`` are written out here rather than called: this is the
    activation's hot loop, and a call that passes arrays costs more than the probe itself.
    """
    k = initial.shape[0]
    mask = slots.shape[0] - 1
    for i in range(k):
        found[i] = initial[i]
        sets[i, i // 64] = np.uint64(1) << np.uint64(i % 64)
        slot = _slot(initial[i], mask)
        while slots[slot] >= 0:
            slot = (slot + 1) & mask
        slots[slot] = i
    m = k
    x = 0
    while x < m:
        parent = found[x]
        count = links[parent, L_COUNT]
        block = links[parent, L_START]
        walk = count <= x  # else look up the pairs with found[:x]
        for i in range(count if walk else x):
            if walk:  # y: the position of the other parent, if found
                child, other = children[block + i, 0], children[block + i, 1]
                y = -1
                slot = _slot(other, mask)
                while slots[slot] >= 0:
                    if found[slots[slot]] == other:
                        y = slots[slot]
                        break
                    slot = (slot + 1) & mask
                if y < 0:
                    continue
            else:
                y = i
                child = _pair_child(parent, found[y], pair_table)
                if child < 0:
                    continue
            slot = _slot(child, mask)  # found already (through its other parent)?
            while slots[slot] >= 0 and found[slots[slot]] != child:
                slot = (slot + 1) & mask
            if slots[slot] >= 0:
                continue
            if m == found.shape[0]:
                return -1
            found[m] = child
            for w in range(sets.shape[1]):
                sets[m, w] = sets[x, w] | sets[y, w]
            slots[slot] = m  # the free slot the probe stopped at
            m += 1
        x += 1
    return m


@njit(cache=True, inline="always")
def _empty_table(capacity):
    """An empty table for a found list of ``capacity``: a power of two, at most 1/4 full."""
    size = 1
    while size < 4 * capacity:
        size *= 2
    return np.full(size, -1, dtype=np.int64)


@njit(cache=True, inline="always")
def _slot(feature, mask):
    """The first probe of ``feature`` in the found list's table (Fibonacci hashing)."""
    z = np.uint64(feature) * np.uint64(0x9E3779B97F4A7C15)
    return np.int64((z >> np.uint64(32)) & np.uint64(mask))


@njit(cache=True)
def _cover(k, found, sets, feat_len):
    """Greedy covering (Alg 19 lines 3-8): largest first, ties to the latest discovered.

    ``found[:k]`` are the initial features, the rest the discovered ones within them; a
    feature is taken if none of its initial features is covered yet.
    """
    m = found.shape[0]
    key = np.empty(m - k, dtype=np.int64)
    for r in range(k, m):  # largest first, then the latest discovered (ids are unique)
        key[r - k] = -((feat_len[found[r]] << 40) + found[r])
    order = np.argsort(key)
    words = sets.shape[1]
    covered = np.zeros(words, dtype=np.uint64)
    out = np.empty(k, dtype=np.int64)
    count = 0
    for r in range(m - k):
        row = k + order[r]
        free = True
        for w in range(words):
            if sets[row, w] & covered[w]:
                free = False
                break
        if free:
            for w in range(words):
                covered[w] |= sets[row, w]
            out[count] = found[row]
            count += 1
    for i in range(k):  # what is left is covered by the initial features themselves
        if not covered[i // 64] & (np.uint64(1) << np.uint64(i % 64)):
            out[count] = found[i]
            count += 1
    return np.sort(out[:count])


@njit(cache=True)
def _compute(initial, feat_len, feat_parents, links, children, pair_table, ints):
    link_children(feat_len, feat_parents, links, children, pair_table, ints)
    found, sets = _features_within(initial, links, children, pair_table)
    if ints[I_SPARSIFY] == 0:
        return np.sort(found)
    return _cover(initial.shape[0], found, sets, feat_len)


@njit(cache=True)
def _cached(initial, key, n, pool, feat_start, feat_len, centry, cpool, ints):
    """The cached φ̇ of ``initial`` (patched forward to n features), or an empty array."""
    k = initial.shape[0]
    row = key & (centry.shape[0] - 1)
    start = centry[row, C_START]
    if (
        centry[row, C_KEY] != key
        or centry[row, C_A_LEN] != k
        or start < ints[I_CACHE_WRITTEN] - cpool.shape[0]
    ):
        return np.empty(0, dtype=np.int64)
    size = cpool.shape[0]
    for t in range(k):
        if cpool[(start + t) % size] != initial[t]:
            return np.empty(0, dtype=np.int64)
    checked = centry[row, C_CHECKED]
    if checked != n:
        if n - checked > PATCH_LIMIT:
            return np.empty(0, dtype=np.int64)
        for f in range(checked, n):
            if _is_subset(pool, feat_start[f], feat_len[f], initial):
                return np.empty(0, dtype=np.int64)
        centry[row, C_CHECKED] = n
    phi = np.empty(centry[row, C_PHI_LEN], dtype=np.int64)
    for t in range(phi.shape[0]):
        phi[t] = cpool[(start + k + t) % size]
    return phi


@njit(cache=True)
def _remember(initial, key, n, phi, centry, cpool, ints):
    """Write (φ⁰, φ̇) at the head of the ring ``cpool`` into row ``key mod rows``.

    Only the row's previous entry and the oldest data the ring overwrites are forgotten.
    """
    k = initial.shape[0]
    need = k + phi.shape[0]
    size = cpool.shape[0]
    if need > size:
        return
    start = ints[I_CACHE_WRITTEN]
    for t in range(k):
        cpool[(start + t) % size] = initial[t]
    for t in range(phi.shape[0]):
        cpool[(start + k + t) % size] = phi[t]
    ints[I_CACHE_WRITTEN] = start + need
    row = key & (centry.shape[0] - 1)
    centry[row, C_KEY] = key
    centry[row, C_START] = start
    centry[row, C_A_LEN] = k
    centry[row, C_PHI_LEN] = phi.shape[0]
    centry[row, C_CHECKED] = n


@njit(cache=True)
def activate(initial, words, pool, feat_start, feat_len, feat_parents, links, children,
             pair_table, ints, centry, cpool):  # fmt: skip
    """φ̇(s) from the sorted initial active features φ⁰(s) (Algorithm 19), cached per set.

    The cache is direct-mapped (row = key of φ⁰ modulo the rows) over a ring of cells: a
    miss overwrites one row, and an entry expires when the ring has wrapped past its cells.
    """
    n = ints[I_NUM_FEATURES]
    if n == ints[I_NUM_INITIAL]:
        return initial.copy()  # nothing discovered: φ̇ = φ⁰
    key = 0
    for i in range(initial.shape[0]):
        key ^= words[initial[i]]
    phi = _cached(initial, key, n, pool, feat_start, feat_len, centry, cpool, ints)
    if phi.shape[0]:
        return phi
    phi = _compute(initial, feat_len, feat_parents, links, children, pair_table, ints)
    _remember(initial, key, n, phi, centry, cpool, ints)
    return phi
