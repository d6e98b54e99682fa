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
- the counters and settings: one-element views of two vectors (`COUNTERS` of int64,
  `SETTINGS` of float64, saved as ``ints`` and ``floats``), so a kernel writes
  ``t.num_features[0]`` through to the saved vector.
- ``links (capacity, NUM_L)``, ``children (4 capacity + 8, 2)`` and ``pair_table``: the
  parent index of Algorithm 19's activation (derived from ``feat_parents``, never saved;
  `link_children` adds new features). Feature p's children lie in one contiguous block of
  ``children`` rows (child, its other parent), so walking them reads memory in order.
- The activation cache (``centry`` rows, ``cpool`` ring) maps an initial active set to its
  sparsified φ̇ together with the feature count it was computed at.

Every kernel takes these as one named value, `IFDDTables` (a numba structref: `new_tables`
builds it, `OnlineIFDD.kernel_tables` returns the representation's own), never as positional
arguments.
"""

from __future__ import annotations

import functools

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.experimental import structref
from numba.extending import intrinsic

__all__ = [
    "COUNTERS",
    "SETTINGS",
    "TABLES",
    "IFDDTables",
    "activate",
    "discover",
    "discover_fitting",
    "discover_room",
    "empty_tables",
    "new_tables",
    "rebuild_table",
    "relevance_of",
    "splitmix64",
]

#: The int64 counters and integer settings, in the order of the saved ``ints`` vector.
#: ``cache_written``, ``linked``, ``children_used`` and ``search_capacity`` belong to the
#: activation cache, the parent index and its search: rebuilt on load, never saved.
COUNTERS = ("num_features", "num_initial", "num_nodes", "pool_used", "num_calls", "num_draws",
            "heap_size", "relevance", "selection", "max_features", "random_word", "sparsify",
            "cache_written", "linked", "children_used", "search_capacity")  # fmt: skip
TRANSIENT_COUNTERS = ("cache_written", "linked", "children_used", "search_capacity")
NUM_INTS = 16
#: The float64 settings, in the order of the saved ``floats`` vector: ξ and C (Eq. 4.6).
SETTINGS = ("threshold", "rate")
#: The tables: (name, numba type), in the order `new_tables` takes them.
TABLES = (
    ("words", types.int64[::1]),
    ("pool", types.int64[::1]),
    ("feat_start", types.int64[::1]),
    ("feat_len", types.int64[::1]),
    ("feat_parents", types.int64[:, ::1]),
    ("node_key", types.int64[::1]),
    ("node_start", types.int64[::1]),
    ("node_len", types.int64[::1]),
    ("node_feature", types.int64[::1]),
    ("node_parents", types.int64[:, ::1]),
    ("node_stats", types.float64[:, ::1]),
    ("node_slot", types.int64[::1]),
    ("heap", types.int64[::1]),
    ("table", types.int64[::1]),
    ("links", types.int64[:, ::1]),
    ("children", types.int64[:, ::1]),
    ("pair_table", types.int64[:, ::1]),
    ("centry", types.int64[:, ::1]),
    ("cpool", types.int64[::1]),
)

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
#: the activation's search walks a parent's block of children when it holds at most this
#: many rows per pair it would look up instead: a walked row is read in order from a short
#: block, a looked-up pair is a random read of ``pair_table`` (a cache miss once the table
#: outgrows the processor's caches, as at 10⁵ features)
WALK_WEIGHT = 8


# ---------------------------------------------------------------------------------------------
# the named state


@structref.register
class IFDDTablesType(types.StructRef):
    """The numba type of `IFDDTables`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class IFDDTables(structref.StructRefProxy):
    """Online iFDD's kernel state by name (a numba structref).

    The tables of the module docstring, the counters (`COUNTERS`) and the settings
    (`SETTINGS`), each counter or setting a one-element array. Built by `new_tables`; read
    and written only by the kernels.
    """


structref.define_boxing(IFDDTablesType, IFDDTables)
_TABLES_TYPE = IFDDTablesType(
    [*TABLES]
    + [(name, types.int64[::1]) for name in COUNTERS]
    + [(name, types.float64[::1]) for name in SETTINGS]
)


@njit(cache=True)
def _new_tables(words, pool, feat_start, feat_len, feat_parents, node_key, node_start,
                node_len, node_feature, node_parents, node_stats, node_slot, heap, table, links,
                children, pair_table, centry, cpool, ints, floats):  # fmt: skip
    t = structref.new(_TABLES_TYPE)
    t.words = words
    t.pool = pool
    t.feat_start = feat_start
    t.feat_len = feat_len
    t.feat_parents = feat_parents
    t.node_key = node_key
    t.node_start = node_start
    t.node_len = node_len
    t.node_feature = node_feature
    t.node_parents = node_parents
    t.node_stats = node_stats
    t.node_slot = node_slot
    t.heap = heap
    t.table = table
    t.links = links
    t.children = children
    t.pair_table = pair_table
    t.centry = centry
    t.cpool = cpool
    t.num_features = ints[0:1]  # the order of COUNTERS
    t.num_initial = ints[1:2]
    t.num_nodes = ints[2:3]
    t.pool_used = ints[3:4]
    t.num_calls = ints[4:5]
    t.num_draws = ints[5:6]
    t.heap_size = ints[6:7]
    t.relevance = ints[7:8]
    t.selection = ints[8:9]
    t.max_features = ints[9:10]
    t.random_word = ints[10:11]
    t.sparsify = ints[11:12]
    t.cache_written = ints[12:13]
    t.linked = ints[13:14]
    t.children_used = ints[14:15]
    t.search_capacity = ints[15:16]
    t.threshold = floats[0:1]  # the order of SETTINGS
    t.rate = floats[1:2]
    return t


def new_tables(tables: dict[str, np.ndarray], ints: np.ndarray, floats: np.ndarray) -> IFDDTables:
    """Return `IFDDTables` over ``tables`` and the counter and setting vectors.

    ``tables`` holds every name of `TABLES` (C-contiguous), ``ints`` the `COUNTERS` (int64)
    and ``floats`` the `SETTINGS` (float64), in order. The arrays are shared, not copied:
    the kernels update them in place.
    """
    return _new_tables(*(tables[name] for name, _ in TABLES), ints, floats)


@functools.cache
def empty_tables() -> IFDDTables:
    """A stand-in `IFDDTables` of empty arrays, for a compiled loop without iFDD."""
    arrays = {
        name: np.zeros(
            (0,) * kind.ndim, dtype=np.float64 if kind.dtype == types.float64 else np.int64
        )
        for name, kind in TABLES
    }
    return new_tables(arrays, np.zeros(NUM_INTS, np.int64), np.zeros(len(SETTINGS)))


# ---------------------------------------------------------------------------------------------
# a cache hint


@intrinsic
def _prefetch(typingctx, array, row):
    """Ask the processor to start loading ``array[row]`` into its caches (LLVM's prefetch).

    A hint only: it changes no value. The activation's search reads one row of ``links``
    per feature it expands, at an address known well before it is needed; at 10⁵ features
    those rows are cache misses that would otherwise be paid one after the other.
    """
    if not isinstance(array, types.Array) or not isinstance(row, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        array_type, row_type = signature.args
        data = context.make_array(array_type)(context, builder, args[0])
        index = context.cast(builder, args[1], row_type, types.intp)
        zeros = [context.get_constant(types.intp, 0)] * (array_type.ndim - 1)
        pointer = cgutils.get_item_pointer2(
            context,
            builder,
            data.data,
            cgutils.unpack_tuple(builder, data.shape),
            cgutils.unpack_tuple(builder, data.strides),
            array_type.layout,
            [index, *zeros],
        )
        byte_pointer = builder.bitcast(pointer, ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        kind = ir.FunctionType(ir.VoidType(), [byte_pointer.type, i32, i32, i32])
        function = cgutils.get_or_insert_function(builder.module, kind, "llvm.prefetch.p0")
        builder.call(function, [byte_pointer, i32(0), i32(3), i32(1)])  # read, keep, data
        return context.get_dummy_value()

    return types.void(array, row), codegen


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
def _pool_remove(heap, node_slot, node, heap_size, node_stats, kind, is_heap):
    pos = node_slot[node]
    last = heap_size[0] - 1
    heap_size[0] = last
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
def splitmix64(x):
    """splitmix64's output for the state before ``x`` (uint64): one mix of x + golden gamma."""
    z = x + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def random_index(random_word, draw, size):
    """The ``draw``-th uniform index in [0, size) of the stream ``random_word`` (counter-based)."""
    z = splitmix64(np.uint64(random_word) + np.uint64(draw) * np.uint64(0xD1B54A32D192ED03))
    u = np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return int(u * size)


# ---------------------------------------------------------------------------------------------
# Algorithms 20 and 21 (and the fixed-rate rule of Eq. 4.6)


@njit(cache=True)
def _make_feature(node, num_features, node_feature, node_start, node_len, node_parents,
                  feat_start, feat_len, feat_parents):  # fmt: skip
    f = num_features[0]
    node_feature[node] = f
    feat_start[f] = node_start[node]
    feat_len[f] = node_len[node]
    feat_parents[f, 0] = node_parents[node, 0]
    feat_parents[f, 1] = node_parents[node, 1]
    num_features[0] = f + 1


@njit(cache=True)
def discover_room(active, t):
    """Σ of the active features' set sizes if `discover` fits in the tables ``t``, else -1.

    Pass the result to `discover_fitting` (the compiled loop checks the room before its step
    and grows the tables if needed; `discover` does both at once).
    """
    feat_len = t.feat_len
    k = active.shape[0]
    num_pairs = k * (k - 1) // 2
    total = 0
    for i in range(k):
        total += feat_len[active[i]]
    num_nodes = t.num_nodes[0]
    if (
        t.pool_used[0] + (k - 1) * total > t.pool.shape[0]
        or num_nodes + num_pairs > t.node_key.shape[0]
        or 2 * (num_nodes + num_pairs) > t.table.shape[0]
    ):
        return -1
    return total


@njit(cache=True)
def fits_discoveries(max_active, count, t):
    """Whether ``count`` discoveries from any sparsified φ̇(s) fit in the tables ``t``.

    Under Algorithm 19 the active features cover disjoint sets of at most ``max_active``
    active initial features, so one discovery needs at most that bound of `discover_room`
    (k ≤ ``max_active`` features whose set sizes sum to at most ``max_active``).
    """
    k = max_active
    num_pairs = count * (k * (k - 1) // 2)
    num_nodes = t.num_nodes[0] + num_pairs
    return (
        t.pool_used[0] + count * (k - 1) * k <= t.pool.shape[0]
        and num_nodes <= t.node_key.shape[0]
        and 2 * num_nodes <= t.table.shape[0]
    )


@njit(cache=True)
def discover(active, td_error, t):
    """Update the relevances of every co-active pair and discover features; Alg 20/21.

    Returns the number of features added (their ids follow the previous count, their parents
    are in ``t.feat_parents``), or -1 before changing anything if a table is too small.
    """
    total = discover_room(active, t)
    if total < 0:
        return -1
    return discover_fitting(active, td_error, total, t)


@njit(cache=True)
def discover_fitting(active, td_error, total, t):
    """`discover` once `discover_room` returned ``total`` >= 0 for the same ``active``."""
    words, pool, feat_start, feat_len = t.words, t.pool, t.feat_start, t.feat_len
    feat_parents, node_key, node_start, node_len = (
        t.feat_parents,
        t.node_key,
        t.node_start,
        t.node_len,
    )
    node_feature, node_parents, node_stats = t.node_feature, t.node_parents, t.node_stats
    node_slot, table, heap = t.node_slot, t.table, t.heap
    num_features, num_nodes, pool_used, heap_size = (
        t.num_features,
        t.num_nodes,
        t.pool_used,
        t.heap_size,
    )
    k = active.shape[0]
    before = num_features[0]
    kind = t.relevance[0]
    selection = t.selection[0]
    max_features = t.max_features[0]
    threshold = t.threshold[0]
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
                node = num_nodes[0]
                num_nodes[0] = node + 1
                start = pool_used[0]
                for c in range(m):  # a loop: see `conjure.compiled.learning_loop._copy`
                    pool[start + c] = buf[c]
                pool_used[0] = start + m
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
                    size = heap_size[0]
                    heap[size] = node
                    node_slot[node] = size
                    heap_size[0] = size + 1
            node_stats[node, 0] += magnitude  # Alg 20 line 4: ψ_f += |δ|
            node_stats[node, 1] += td_error  # Alg 21 line 4: Δ_f += δ
            node_stats[node, 2] += 1.0  # Alg 21 line 5: ν_f += 1
            node_parents[node, 0] = g
            node_parents[node, 1] = h
            if selection == SELECT_THRESHOLD:
                # Alg 20 line 5 / Alg 21 line 7: discover when ψ_f > ξ
                if (
                    relevance_of(node_stats[node], kind) > threshold
                    and num_features[0] < max_features
                ):
                    _make_feature(node, num_features, node_feature, node_start, node_len,
                                  node_parents, feat_start, feat_len, feat_parents)  # fmt: skip
            elif selection == SELECT_RATE_RELEVANCE:
                pos = node_slot[node]
                _sift_up(heap, node_slot, pos, node_stats, kind)
                _sift_down(heap, node_slot, node_slot[node], heap_size[0], node_stats, kind)
    num_calls = t.num_calls
    num_calls[0] += 1
    if selection != SELECT_THRESHOLD:
        # Eq. 4.6: keep n_t = n_0 + floor(sqrt(C t)) features
        target = t.num_initial[0] + int(np.floor(np.sqrt(t.rate[0] * num_calls[0])))
        target = min(target, max_features)
        is_heap = selection == SELECT_RATE_RELEVANCE
        num_draws = t.num_draws
        while num_features[0] < target and heap_size[0] > 0:
            if is_heap:
                node = heap[0]
            else:
                pick = random_index(t.random_word[0], num_draws[0], heap_size[0])
                num_draws[0] += 1
                node = heap[pick]
            _pool_remove(heap, node_slot, node, heap_size, node_stats, kind, is_heap)
            _make_feature(node, num_features, node_feature, node_start, node_len, node_parents,
                          feat_start, feat_len, feat_parents)  # fmt: skip
    return num_features[0] - before


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
def link_children(t):
    """Index the features discovered since the last call by their parents.

    Feature f = g ∪ h is a row (f, h) in g's block of ``children`` and (f, g) in h's.
    ``pair_table`` (open addressing) finds the feature whose parents are a given pair.
    Features of one initial feature (ARiFDD's split tiles) have no parents to index.
    """
    feat_len, feat_parents, links, children = t.feat_len, t.feat_parents, t.links, t.children
    pair_table, used = t.pair_table, t.children_used
    n = t.num_features[0]
    mask = pair_table.shape[0] - 1
    for f in range(t.linked[0], n):
        if feat_len[f] < 2:
            continue
        a = min(feat_parents[f, 0], feat_parents[f, 1])
        b = max(feat_parents[f, 0], feat_parents[f, 1])
        _add_child(a, f, b, links, children, used)
        _add_child(b, f, a, links, children, used)
        slot = _pair_slot(a, b, mask)
        while pair_table[slot, 0] != -1:
            slot = (slot + 1) & mask
        pair_table[slot, 0] = f
        pair_table[slot, 1] = a
        pair_table[slot, 2] = b
    t.linked[0] = n


@njit(cache=True, inline="always")
def _add_child(parent, child, other, links, children, used):
    """Append the row (child, other) to parent's block, moving a full block to the end.

    ``used`` is the one-element count of ``children`` rows in use (``children_used``).
    """
    count = links[parent, L_COUNT]
    if count == links[parent, L_CAPACITY]:
        _move_block(parent, max(4, 2 * count), links, children, used)
    row = links[parent, L_START] + count
    children[row, 0] = child
    children[row, 1] = other
    links[parent, L_COUNT] = count + 1


@njit(cache=True)
def _move_block(parent, capacity, links, children, used):
    """Give parent's block ``capacity`` rows at the end of ``children`` (compacting if full).

    The old rows become garbage until `_compact`. ``children`` holds 4 C + 8 rows for C
    features: the live rows are two per feature (at most 2 C) and a block at most doubles
    (at most 2 C more), so after compaction the block always fits.
    """
    if used[0] + capacity > children.shape[0]:
        _compact(links, children, used)
    start = used[0]
    old = links[parent, L_START]
    for t in range(links[parent, L_COUNT]):
        children[start + t, 0] = children[old + t, 0]
        children[start + t, 1] = children[old + t, 1]
    links[parent, L_START] = start
    links[parent, L_CAPACITY] = capacity
    used[0] = start + capacity


@njit(cache=True)
def _compact(links, children, used):
    """Pack every block to its live rows, in feature order, dropping the garbage."""
    live = np.empty((used[0], 2), dtype=np.int64)
    rows = 0
    for p in range(links.shape[0]):
        old = links[p, L_START]
        count = links[p, L_COUNT]
        for t in range(count):
            live[rows + t, 0] = children[old + t, 0]
            live[rows + t, 1] = children[old + t, 1]
        links[p, L_START] = rows
        links[p, L_CAPACITY] = count
        rows += count
    for r in range(rows):
        children[r, 0] = live[r, 0]
        children[r, 1] = live[r, 1]
    used[0] = rows


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
def _features_within(initial, links, children, pair_table, search_capacity):
    """Every feature whose initial set lies within ``initial``, found from the parent index.

    Returns the found features (the initial ones first) and their initial sets as bit sets
    over the positions in ``initial`` (row i is found[i]'s; ``words`` uint64 words a row).
    The found list starts with room for 16 k features, or the ``search_capacity[0]`` an
    earlier search needed, and doubles (starting again, and kept in ``search_capacity``) if
    full: as features accumulate within the active sets, the searches stop restarting.
    """
    k = initial.shape[0]
    words = (k + 63) // 64
    capacity = max(16 * k, 64, search_capacity[0])
    while True:
        found = np.empty(capacity, dtype=np.int64)
        sets = np.zeros((capacity, words), dtype=np.uint64)
        slots = _empty_table(capacity)
        m = _expand(initial, links, children, pair_table, found, sets, slots)
        if m >= 0:
            return found[:m], sets[:m]
        capacity *= 2
        search_capacity[0] = capacity


@njit(cache=True)
def _expand(initial, links, children, pair_table, found, sets, slots):
    """Fill the found list from ``initial``; return its length, or -1 if it does not fit.

    A discovered feature f = g ∪ h lies within the set exactly when both parents do, so it is
    found when the first of its parents to be expanded, at position x of the found list, is
    expanded with the other already found: either by walking that parent's block of children
    (keeping those whose other parent is found) or by looking up its pairs with the x
    features found before it, whichever is cheaper (a walk while the block holds at most
    `WALK_WEIGHT` rows per lookup). The cost is at most Θ(m²) for the m features found and
    never depends on n_t; which features are found is looked up in
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
        if x + 1 < m:  # the next parent's block (its links row was prefetched when found)
            _prefetch(children, links[found[x + 1], L_START])
        parent = found[x]
        count = links[parent, L_COUNT]
        block = links[parent, L_START]
        walk = count <= WALK_WEIGHT * x  # else look up the pairs with found[:x]
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
            _prefetch(links, child)  # its row is read when it is expanded, later
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
def _cover(k, found, sets):
    """Greedy covering (Alg 19 lines 3-8): largest first, ties to the latest discovered.

    ``found[:k]`` are the initial features, the rest the discovered ones within them; a
    feature is taken if none of its initial features is covered yet. A feature's size is
    the number of bits of its row of ``sets`` (its initial set), so the cover reads no
    per-feature table.

    Choice: instead of sorting the m − k discovered features, each pass takes the first
    feature of that order among those still disjoint from the cover (the largest key), which
    is the feature the sorted walk would take next: a feature the walk skipped meets the
    cover, and still does once the cover grew. Each pass keeps only the disjoint candidates,
    so the cost is O(m · picks) (picks ≤ k) rather than a sort's O(m log m) with indirection.
    """
    m = found.shape[0]
    words = sets.shape[1]
    candidates = np.empty(m - k, dtype=np.int64)  # rows of `found` still disjoint
    keys = np.empty(m - k, dtype=np.int64)  # their keys: size, then id
    for r in range(k, m):  # largest first, then the latest discovered (ids are unique)
        size = 0
        for w in range(words):
            bits = sets[r, w]
            while bits:
                bits &= bits - np.uint64(1)
                size += 1
        candidates[r - k] = r
        keys[r - k] = (size << 40) + found[r]
    covered = np.zeros(words, dtype=np.uint64)
    out = np.empty(k, dtype=np.int64)
    count = 0
    alive = m - k
    while alive > 0:
        best = -1
        kept = 0
        for c in range(alive):  # drop the candidates that meet the cover; find the largest
            row = candidates[c]
            free = True
            for w in range(words):
                if sets[row, w] & covered[w]:
                    free = False
                    break
            if free:
                candidates[kept], keys[kept] = row, keys[c]
                if best < 0 or keys[kept] > keys[best]:
                    best = kept
                kept += 1
        alive = kept
        if best < 0:
            break
        row = candidates[best]
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
def _compute(initial, t):
    link_children(t)
    found, sets = _features_within(initial, t.links, t.children, t.pair_table, t.search_capacity)
    if t.sparsify[0] == 0:
        return np.sort(found)
    return _cover(initial.shape[0], found, sets)


@njit(cache=True)
def _cached(initial, key, n, pool, feat_start, feat_len, centry, cpool, written):
    """The cached φ̇ of ``initial`` (patched forward to n features), or an empty array."""
    k = initial.shape[0]
    row = key & (centry.shape[0] - 1)
    start = centry[row, C_START]
    if (
        centry[row, C_KEY] != key
        or centry[row, C_A_LEN] != k
        or start < written[0] - cpool.shape[0]
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
def _remember(initial, key, n, phi, centry, cpool, written):
    """Write (φ⁰, φ̇) at the head of the ring ``cpool`` into row ``key mod rows``.

    Only the row's previous entry and the oldest data the ring overwrites are forgotten.
    """
    k = initial.shape[0]
    need = k + phi.shape[0]
    size = cpool.shape[0]
    if need > size:
        return
    start = written[0]
    for t in range(k):
        cpool[(start + t) % size] = initial[t]
    for t in range(phi.shape[0]):
        cpool[(start + k + t) % size] = phi[t]
    written[0] = start + need
    row = key & (centry.shape[0] - 1)
    centry[row, C_KEY] = key
    centry[row, C_START] = start
    centry[row, C_A_LEN] = k
    centry[row, C_PHI_LEN] = phi.shape[0]
    centry[row, C_CHECKED] = n


@njit(cache=True)
def activate(initial, t):
    """φ̇(s) from the sorted initial active features φ⁰(s) (Algorithm 19), cached per set.

    The cache is direct-mapped (row = key of φ⁰ modulo the rows) over a ring of cells: a
    miss overwrites one row, and an entry expires when the ring has wrapped past its cells.
    """
    n = t.num_features[0]
    if n == t.num_initial[0]:
        return initial.copy()  # nothing discovered: φ̇ = φ⁰
    words = t.words
    key = 0
    for i in range(initial.shape[0]):
        key ^= words[initial[i]]
    phi = _cached(initial, key, n, t.pool, t.feat_start, t.feat_len, t.centry, t.cpool,
                  t.cache_written)  # fmt: skip
    if phi.shape[0]:
        return phi
    phi = _compute(initial, t)
    _remember(initial, key, n, phi, t.centry, t.cpool, t.cache_written)
    return phi
