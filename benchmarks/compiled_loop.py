"""Learning steps per second: the compiled path vs the Python path vs a hand-written numba loop.

Usage: ``python benchmarks/compiled_loop.py [--steps N] [--repeats R] [--no-compile-times]``

Workload: SARSA + tile coding (8 tilings of 10x10) with ε-greedy (ε = 0.1) and a
constant step size on the inverted pendulum, measured three ways side by side, interleaved
repeat by repeat with the RBF workload below (the machine is shared; the median of
``repeats`` is reported):

- ``python``: `conjure.experiments.loop.LearningLoop.advance` (six Python-to-numba calls per
  step);
- ``compiled``: `conjure.compiled.for_combination(...).advance` (one numba call per advance);
- ``hand-written``: `reference_loop` below, one numba function doing the same arithmetic with
  preallocated buffers and no library code: the limit the compiled path is compared against.
  It is given the compiled path's seeds and the same number of steps, and the run ends by
  saying whether the two left θ bit for bit equal (``tests/test_benchmarks.py`` checks it).
- ``decaying α``: `decaying_reference_loop` below, a second hand-written numba function for
  the same workload with the thesis's decaying step size (Section 4.1.4, α₀ = 1, N₀ = 100,
  over the 8 active features) drawn from one generator: the practical limit of a learner with
  that schedule, timed interleaved with the others. It draws differently from the compiled
  path, so it is a cost reference only (no θ comparison).

Second workload: SARSA + Gaussian RBF (3x3 centers plus a bias, real-valued φ) with the same
policy and step size on the pendulum, ``python`` and ``compiled`` paths side by side (the
compiled path runs the kernel's real-valued compilation).

Compile times are measured for each workload in fresh processes with an empty numba cache
(``cold``, the first run on a machine) and then with that cache filled (``warm``, every later
process).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numpy as np
from numba import njit
from rich.console import Console
from rich.table import Table

from conjure.agents import SARSA
from conjure.compiled import for_combination
from conjure.domains import InvertedPendulum
from conjure.experiments.loop import LearningLoop
from conjure.policies import EpsilonGreedy
from conjure.representations import RBF, TileCoding

NUM_TILINGS, TILES, EPSILON, STEP_SIZE = 8, 10, 0.1, 0.05
WORKLOADS = ("tiles", "rbf")


def make_agent(workload: str = "tiles") -> SARSA:
    if workload == "rbf":
        representation = RBF(num_centers=3)
    else:
        representation = TileCoding(num_tilings=NUM_TILINGS, tiles_per_dim=TILES)
    return SARSA(
        representation=representation,
        policy=EpsilonGreedy(epsilon=EPSILON),
        step_size=STEP_SIZE,
    )


# ---------------------------------------------------------------------------------------------
# The hand-written reference: pendulum RK4 + tile coding + ε-greedy + SARSA in one function.
#
# It does the compiled path's arithmetic in the compiled path's order with the same draws
# (`tests/test_benchmarks.py` checks θ bit for bit): the domain's force noise from the
# domain's generator, one uniform per action choice from the agent's, the first episode
# after ``domain.reset(seed=...)``, and no library code. The constants are the workload's
# (`InvertedPendulum()`: force noise 10 N, start (0, 0) with no draw, γ = 0.95, cap 3000).

HALF_PI = math.pi / 2.0
FORCE_NOISE, DISCOUNT, CAP = 10.0, 0.95, 3000
_QUANTA = TILES * NUM_TILINGS  # a dimension's width in 1/NUM_TILINGS tiles
_THETA_SCALE = _QUANTA / (HALF_PI - -HALF_PI)  # quanta per radian over [-π/2, π/2]
_RATE_SCALE = _QUANTA / (2.0 - -2.0)  # quanta per rad/s over [-2, 2]
_SIDE = TILES + 1  # tiles per dimension per tiling (offset tilings need one more)


@njit(cache=True, inline="always")
def _acceleration(theta: float, rate: float, force: float) -> float:
    alpha = 1.0 / 10.0  # 1 / (m + M)
    cos_theta = math.cos(theta)
    numerator = (
        9.8 * math.sin(theta)
        - alpha * 2.0 * 0.5 * rate * rate * math.sin(2.0 * theta) / 2.0
        - alpha * cos_theta * force
    )
    return numerator / (4.0 * 0.5 / 3.0 - alpha * 2.0 * 0.5 * cos_theta**2)


@njit(cache=True, inline="always")
def _rk4(theta: float, rate: float, force: float) -> tuple[float, float]:
    # One 0.1 s RK4 step of (θ, θ̇); θ̇ clipped to [-2, 2] after it.
    dt = 0.1
    k1t, k1r = rate, _acceleration(theta, rate, force)
    k2t = rate + 0.5 * dt * k1r
    k2r = _acceleration(theta + 0.5 * dt * k1t, k2t, force)
    k3t = rate + 0.5 * dt * k2r
    k3r = _acceleration(theta + 0.5 * dt * k2t, k3t, force)
    k4t = rate + dt * k3r
    k4r = _acceleration(theta + dt * k3t, k4t, force)
    theta += dt / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t)
    rate = min(max(rate + dt / 6.0 * (k1r + 2.0 * k2r + 2.0 * k3r + k4r), -2.0), 2.0)
    return theta, rate


@njit(cache=True, inline="always")
def _tiles(theta: float, rate: float, out: np.ndarray) -> None:
    # Positions in 1/NUM_TILINGS tiles; tiling t shifts θ by t and θ̇ by 3t quanta (mod 8).
    q0 = min(max(int((theta + HALF_PI) * _THETA_SCALE), 0), _QUANTA)
    q1 = min(max(int((rate + 2.0) * _RATE_SCALE), 0), _QUANTA)
    for t in range(NUM_TILINGS):
        c0 = (q0 + t % NUM_TILINGS) // NUM_TILINGS
        c1 = (q1 + (3 * t) % NUM_TILINGS) // NUM_TILINGS
        out[t] = t * _SIDE * _SIDE + c0 * _SIDE + c1


@njit(cache=True, inline="always")
def _choose(weights: np.ndarray, active: np.ndarray, q: np.ndarray, u: float) -> int:
    # Q(s, ·) into q, then ε-greedy from one uniform u: explore if u < ε, else the k-th of
    # the tied best actions, k from the rest of u.
    q[:] = 0.0
    for i in range(active.shape[0]):
        for a in range(3):
            q[a] += weights[active[i], a]
    if u < EPSILON:
        return min(int(u / EPSILON * 3), 2)
    best, ties = -np.inf, 0
    for a in range(3):
        if q[a] > best:
            best, ties = q[a], 1
        elif q[a] == best:
            ties += 1
    k = min(int((u - EPSILON) / (1.0 - EPSILON) * ties), ties - 1)
    for a in range(3):
        if q[a] == best:
            if k == 0:
                return a
            k -= 1
    return 2


def reference_state(cap: int = CAP) -> tuple[np.ndarray, np.ndarray]:
    """`reference_loop`'s resumable state before the first step: (θ, θ̇), (t, a)."""
    return np.zeros(2), np.array([cap, 0], dtype=np.int64)


@njit(cache=True)
def reference_loop(
    num_steps: int,
    weights: np.ndarray,
    domain_rng: np.random.Generator,
    agent_rng: np.random.Generator,
    pendulum: np.ndarray,
    progress: np.ndarray,
    cap: int = CAP,
) -> int:
    """Run ``num_steps`` SARSA steps; return the number of episodes begun.

    ``pendulum`` (θ, θ̇) and ``progress`` (steps into the episode, chosen action) carry an
    episode across calls (`reference_state`); t >= ``cap`` begins a new episode (after a fall
    t is set to ``cap``).
    """
    active = np.empty(NUM_TILINGS, dtype=np.int64)
    next_active = np.empty(NUM_TILINGS, dtype=np.int64)
    q = np.empty(3)
    theta, rate = pendulum[0], pendulum[1]
    length, action = progress[0], progress[1]
    episodes = 0
    if length < cap:
        _tiles(theta, rate, active)
    for _ in range(num_steps):
        if length >= cap:  # reset to (0, 0) (no draw), begin an episode, a = π(s)
            theta = rate = 0.0
            episodes += 1
            length = 0
            _tiles(theta, rate, active)
            action = _choose(weights, active, q, agent_rng.random())
        force = 50.0 * (action - 1)
        force += FORCE_NOISE * (2.0 * domain_rng.random() - 1.0)
        theta, rate = _rk4(theta, rate, force)
        length += 1
        terminated = not (-HALF_PI < theta < HALF_PI)
        next_action = 0
        if terminated:  # r = -1, no bootstrap
            target = -1.0
        else:  # r = 0; φ(s'), a' = π(s'), r + γ Q(s', a')
            _tiles(theta, rate, next_active)
            next_action = _choose(weights, next_active, q, agent_rng.random())
            target = 0.0 + DISCOUNT * q[next_action]
        value = 0.0
        for i in range(NUM_TILINGS):
            value += weights[active[i], action]
        change = STEP_SIZE * (target - value)
        for i in range(NUM_TILINGS):
            weights[active[i], action] += change
        if terminated:
            length = cap
        else:
            active, next_active = next_active, active
            action = next_action
    pendulum[0], pendulum[1] = theta, rate
    progress[0], progress[1] = length, action
    return episodes


# ---------------------------------------------------------------------------------------------
# Measurement


def _rate(advance, num_steps: int) -> float:
    started = time.perf_counter()
    advance(num_steps)
    return num_steps / (time.perf_counter() - started)


def _paths(workload: str, num_steps: int) -> tuple[dict, SARSA]:
    """The Python and compiled paths of ``workload`` and the compiled path's agent."""
    domain = InvertedPendulum()
    python_loop = LearningLoop(domain, make_agent(workload).setup(domain.domain_spec, 0), seed=0)
    domain = InvertedPendulum()
    agent = make_agent(workload).setup(domain.domain_spec, 0)
    stepper = for_combination(domain, agent, seed=0)
    paths = {
        (workload, "python"): (python_loop.advance, max(num_steps // 20, 1_000)),
        (workload, "compiled"): (stepper.advance, num_steps),
    }
    return paths, agent


def hand_written(seed: int = 0, cap: int = CAP) -> tuple[Callable[[int], int], np.ndarray]:
    """`reference_loop` with the generators the compiled path gets for ``seed``: (advance, θ).

    The domain's generator is the one ``InvertedPendulum().reset(seed=seed)`` seeds and the
    agent's is ``make_agent().setup(spec, seed).rng_``, so equal step counts give the compiled
    path's θ bit for bit.
    """
    domain = InvertedPendulum()
    domain.reset(seed=seed)
    agent_rng = make_agent().setup(domain.domain_spec, seed).rng_
    weights = np.zeros((_SIDE * _SIDE * NUM_TILINGS, 3))
    pendulum, progress = reference_state(cap)

    def advance(num_steps: int) -> int:
        return reference_loop(
            num_steps, weights, domain.np_random, agent_rng, pendulum, progress, cap
        )

    return advance, weights


@njit(cache=True)
def decaying_reference_loop(num_steps: int, rng: np.random.Generator) -> float:
    """Run ``num_steps`` SARSA steps from θ = 0 with a decaying step size; return Σ δ.

    The step size of episode e is α₀/k · (N₀ + 1)/(N₀ + e^1.1) with α₀ = 1, N₀ = 100 and k = 8
    active features (the thesis's schedule, Section 4.1.4); ε-greedy and the force noise draw
    from ``rng``. The sum of TD errors is returned so that no step can be optimised away.
    """
    weights = np.zeros((_SIDE * _SIDE * NUM_TILINGS, 3))
    active = np.empty(NUM_TILINGS, dtype=np.int64)
    next_active = np.empty(NUM_TILINGS, dtype=np.int64)
    q = np.empty(3)
    theta = rate = 0.0
    episode, length = 1, 0
    _tiles(theta, rate, active)
    action = _choose(weights, active, q, rng.random())
    total = 0.0
    for _ in range(num_steps):
        force = 50.0 * (action - 1) + FORCE_NOISE * (2.0 * rng.random() - 1.0)
        theta, rate = _rk4(theta, rate, force)
        length += 1
        terminated = not (-HALF_PI < theta < HALF_PI)
        value = 0.0
        for i in range(NUM_TILINGS):
            value += weights[active[i], action]
        next_action = 0
        if terminated:
            delta = -1.0 - value
        else:
            _tiles(theta, rate, next_active)
            next_action = _choose(weights, next_active, q, rng.random())
            delta = DISCOUNT * q[next_action] - value
        step_size = 1.0 / NUM_TILINGS * 101.0 / (100.0 + episode**1.1)
        for i in range(NUM_TILINGS):
            weights[active[i], action] += step_size * delta
        total += delta
        if terminated or length >= CAP:
            theta = rate = 0.0
            episode, length = episode + 1, 0
            _tiles(theta, rate, active)
            action = _choose(weights, active, q, rng.random())
        else:
            active, next_active = next_active, active
            action = next_action
    return total


def decaying(seed: int = 0) -> Callable[[int], float]:
    """`decaying_reference_loop` as an advance taking a step count (fresh weights per call)."""
    rng = np.random.default_rng(seed)
    return lambda num_steps: decaying_reference_loop(num_steps, rng)


def runners(num_steps: int) -> tuple[dict, Callable[[], bool]]:
    """Every measured path, keyed by (workload, path), and whether the tile paths' θ agree."""
    tiles, agent = _paths("tiles", num_steps)
    rbf, _ = _paths("rbf", num_steps)
    advance, weights = hand_written(0)
    paths = {**tiles, ("tiles", "hand-written"): (advance, num_steps)}
    paths["tiles", "decaying α"] = (decaying(0), num_steps)
    paths.update(rbf)
    return paths, lambda: np.array_equal(agent.weights_, weights)


_COMPILE_SNIPPET = """
import time
started = time.perf_counter()
from compiled_loop import make_agent
from conjure.compiled import compile_seconds, for_combination
from conjure.domains import InvertedPendulum
imported = time.perf_counter() - started
domain = InvertedPendulum()
agent = make_agent(sys.argv[1]).setup(domain.domain_spec, 0)
for_combination(domain, agent, seed=0).advance(1)
print(compile_seconds(), imported)
"""


def compile_times(workload: str) -> dict[str, tuple[float, float]]:
    """(kernel compile or load seconds, import seconds) in fresh processes: cold, then warm."""
    here = os.path.dirname(os.path.abspath(__file__))
    times = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("cold", "warm"):
            out = subprocess.run(
                [sys.executable, "-c", "import sys\n" + _COMPILE_SNIPPET, workload],
                cwd=here,
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout.split()
            times[label] = (float(out[0]), float(out[1]))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2_000_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-compile-times", action="store_true")
    args = parser.parse_args()
    table, is_same_work = runners(args.steps)
    for advance, _ in table.values():
        advance(2_000)  # warm-up: compilation or cache loading
    rates: dict[str, list[float]] = {name: [] for name in table}
    for _ in range(args.repeats):
        for name, (advance, num_steps) in table.items():
            rates[name].append(_rate(advance, num_steps))
    medians = {name: statistics.median(values) for name, values in rates.items()}
    titles = {
        "tiles": (f"SARSA + TileCoding({NUM_TILINGS} x {TILES}x{TILES})", "hand-written"),
        "rbf": ("SARSA + RBF(3x3 + bias)", "compiled"),
    }
    console = Console()
    from call_cost import cpu_model  # here: call_cost imports this module

    console.print(f"CPU: {cpu_model()}; load average: {os.getloadavg()}")
    for workload, (title, reference_path) in titles.items():
        reference = medians[(workload, reference_path)]
        out = Table(title=f"{title}, InvertedPendulum (median of {args.repeats}, interleaved)")
        for column in ("path", "steps/s", "µs/step", f"x {reference_path}"):
            out.add_column(column, justify="right")
        for (kind, path), rate in medians.items():
            if kind == workload:
                out.add_row(path, f"{rate:,.0f}", f"{1e6 / rate:.3f}", f"{reference / rate:.2f}")
        console.print(out)
    ratio = medians["tiles", "decaying α"] / medians["tiles", "compiled"]
    console.print(f"compiled path / hand-written loop with decaying α, µs per step: {ratio:.2f}x")
    # Equal step counts (warm-up included): the same arithmetic gives the same θ bit for bit.
    same = "yes" if is_same_work() else "NO: the reference does other work"
    console.print(f"hand-written θ == compiled θ after the same steps: {same}")
    if not args.no_compile_times:
        for workload in WORKLOADS:
            for label, (seconds, imported) in compile_times(workload).items():
                console.print(
                    f"{workload}, {label} numba cache: first kernel call {seconds:.2f} s "
                    f"(import {imported:.2f} s)"
                )


if __name__ == "__main__":
    main()
