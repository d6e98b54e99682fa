"""The benchmarks' hand-written references do the library's arithmetic.

`benchmarks/compiled_loop.py` reports the compiled path's speed as a multiple of
`reference_loop`, a hand-written numba loop; the ratio means something only if both do the
same work. With the same seeds they must leave θ bit for bit equal.
"""

import importlib.util
import sys
from pathlib import Path

import numpy as np

from conjure.compiled import for_combination
from conjure.domains import InvertedPendulum
from conjure.experiments.loop import Stepper

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "compiled_loop.py"


def load_benchmark():
    # Registered in sys.modules under its own name: numba's disk cache records a cached
    # function's module, and an entry written from an unregistered module ("<dynamic>") fails
    # to load in the benchmark script's later processes (ModuleNotFoundError).
    if "compiled_loop" not in sys.modules:
        spec = importlib.util.spec_from_file_location("compiled_loop", BENCHMARK)
        module = importlib.util.module_from_spec(spec)
        sys.modules["compiled_loop"] = module
        spec.loader.exec_module(module)
    return sys.modules["compiled_loop"]


def test_reference_loop_leaves_the_compiled_paths_weights_bit_for_bit():
    benchmark = load_benchmark()
    seed, chunks = 3, (1, 6_999, 12_000)  # 20,000 steps; the calls split episodes
    domain = InvertedPendulum()
    agent = benchmark.make_agent().setup(domain.domain_spec, seed)
    stepper = for_combination(domain, agent, seed=seed)
    advance, weights = benchmark.hand_written(seed)
    episodes = 0
    terminal_steps = 0
    for num_steps in chunks:
        stats = stepper.advance(num_steps)
        terminal_steps += int(stats.num_failures)
        episodes += advance(num_steps)
    # Several episodes, most ending in a fall (the terminal step, r = -1, no bootstrap).
    assert stepper.num_episodes >= 5 and terminal_steps >= 4
    assert episodes == stepper.num_episodes
    assert np.count_nonzero(agent.weights_) > 100
    np.testing.assert_array_equal(weights, agent.weights_)


def test_reference_loop_truncates_at_the_cap_as_the_library_does():
    # No episode reaches the 3000-step cap in these runs (ε = 0.1 and the noise make the pole
    # fall first), so the cap's step (bootstrapped, then a reset) is checked with a cap of 12
    # against the Python stepper, which takes the cap as a parameter and calls the same kernels.
    benchmark = load_benchmark()
    seed, cap = 5, 12
    domain = InvertedPendulum()
    agent = benchmark.make_agent().setup(domain.domain_spec, seed)
    stepper = Stepper(domain, agent, seed=seed, max_episode_steps=cap)
    advance, weights = benchmark.hand_written(seed, cap=cap)
    episodes, lengths = 0, []
    for _ in range(3_000):  # one step per call: the reference resumes its episode each time
        stepper.advance(1)
        episodes += advance(1)
        if not stepper.is_mid_episode:
            lengths.append(stepper.last_episode.num_steps)
    assert lengths.count(cap) >= 20 and min(lengths) < cap  # truncations and falls
    assert episodes == stepper.num_episodes
    np.testing.assert_array_equal(weights, agent.weights_)


def test_reference_loop_continues_an_episode_across_calls():
    benchmark = load_benchmark()
    advance, weights = benchmark.hand_written(0)
    once, once_weights = benchmark.hand_written(0)
    assert advance(2_500) + advance(2_500) == once(5_000)
    np.testing.assert_array_equal(weights, once_weights)


def test_the_decaying_step_size_reference_learns_deterministically_for_a_seed():
    benchmark = load_benchmark()
    first, second = benchmark.decaying(3), benchmark.decaying(3)
    total = first(5_000)
    assert np.isfinite(total) and total != 0.0
    assert second(5_000) == total
