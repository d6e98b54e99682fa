"""Seeds: one integer per run, split with ``numpy.random.SeedSequence``; no global RNG anywhere."""

from __future__ import annotations

from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError

__all__ = [
    "as_seed_sequence",
    "make_rng",
    "rng_from_state",
    "rng_state",
    "seed_to_int",
    "split_seed",
]

Seed = int | np.random.SeedSequence


def as_seed_sequence(seed: Seed) -> np.random.SeedSequence:
    """Return ``seed`` as a SeedSequence; a seed must be a non-negative int or a SeedSequence."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        return np.random.SeedSequence(int(seed))
    raise InvalidParameterError(
        f"`seed` must be a non-negative int or a numpy SeedSequence; got {seed!r}."
    )


def split_seed(seed: Seed, names: tuple[str, ...]) -> dict[str, np.random.SeedSequence]:
    """Split one seed into independent child seeds, one per name, in the order given.

    Examples
    --------
    >>> seeds = split_seed(7, ("domain", "agent"))
    >>> sorted(seeds)
    ['agent', 'domain']
    >>> int(make_rng(seeds["agent"]).integers(100)) == int(make_rng(split_seed(7, ("domain", "agent"))["agent"]).integers(100))
    True
    """  # noqa: E501
    children = as_seed_sequence(seed).spawn(len(names))
    return dict(zip(names, children, strict=True))


def make_rng(seed: Seed) -> np.random.Generator:
    """Return a PCG64 generator for ``seed``."""
    return np.random.Generator(np.random.PCG64(as_seed_sequence(seed)))


def seed_to_int(seed: np.random.SeedSequence) -> int:
    """Return a 32-bit integer drawn from ``seed`` (for APIs such as ``Env.reset(seed=...)``)."""
    return int(seed.generate_state(1, dtype=np.uint32)[0])


def rng_state(rng: np.random.Generator) -> dict[str, Any]:
    """Return the generator's full state as a JSON-able dict."""
    return rng.bit_generator.state


def rng_from_state(state: dict[str, Any]) -> np.random.Generator:
    """Rebuild a generator from :func:`rng_state`'s output."""
    name = state["bit_generator"]
    if name != "PCG64":
        raise InvalidParameterError(f"Only PCG64 generator states can be restored; got {name!r}.")
    bit_generator = np.random.PCG64()
    bit_generator.state = state
    return np.random.Generator(bit_generator)
