"""Preloaded by the local pool's forkserver: numba and the loop's compilations already cached.

The pool's workers fork from the forkserver, so what it loaded before forking (numba, LLVM and
the compiled loop's code) stays shared with it instead of being loaded again by every worker
into its private memory (`benchmarks/worker_memory.py` measures it). Only compilations found
in numba's disk cache are loaded (`conjure.compiled.warm_up` with ``cached_only``): a cold one
is compiled by the warm-up's worker (`conjure.experiments.parallel.warm_up`), never here, and
anything that fails here only costs the workers that memory (an exception would stop the
forkserver). Never import it elsewhere.
"""

from contextlib import suppress

with suppress(Exception):
    from conjure.compiled import warm_up

    warm_up(cached_only=True)
