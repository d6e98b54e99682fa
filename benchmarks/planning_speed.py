"""Planning speed: conjure's VI/PI on sparse GridWorlds and LSPI on 10^5 samples.

Run: ``python benchmarks/planning_speed.py [--sizes 100 316 1000] [--skip-lspi]``.
Side by side: a plain vectorised scipy value iteration (the bar) and, if installed,
``pymdptoolbox`` (``pip install pymdptoolbox``) on the same models.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from conjure.agents.lspi import LSPI
from conjure.core.interfaces import DomainSpec, Transition
from conjure.domains.gridworld import GridWorld, open_grid
from conjure.planners import PolicyIteration, ValueIteration
from conjure.representations import TileCoding

DISCOUNT, TOLERANCE = 0.95, 1e-6


def plain_scipy_vi(model):
    stacked, rewards = model.stacked_transitions, model.rewards_by_action
    live = ~model.is_terminal
    values = np.zeros(model.num_states)
    started = time.perf_counter()
    for iteration in range(1, 100_000):
        iterations = iteration
        q = rewards + DISCOUNT * (stacked @ values).reshape(model.num_actions, -1)
        new = q.max(axis=0) * live
        change = np.abs(new - values).max()
        values = new
        if change < TOLERANCE:
            break
    return time.perf_counter() - started, iterations, values


def mdptoolbox_vi(model, budget_states=20_000):
    try:
        import mdptoolbox.mdp
    except ImportError:
        return "not installed (pip install pymdptoolbox)"
    if model.num_states > budget_states:
        return "skipped (dense bound computation; would allocate |A||S|^2 floats)"
    started = time.perf_counter()
    vi = mdptoolbox.mdp.ValueIteration(
        [p.tocsr() for p in model.transitions], model.rewards, DISCOUNT, epsilon=TOLERANCE
    )
    vi.run()
    return f"{time.perf_counter() - started:.2f} s ({vi.iter} iterations)"


def planning(sizes):
    ValueIteration().plan(GridWorld(map_name="4x5").model())  # compile the numba kernel
    print(
        f"{'states':>9} {'build':>7} {'model':>7} {'plain VI':>9} {'conjure VI':>11} "
        f"{'iters':>6} {'conjure PI':>11} {'PI iters':>8}  pymdptoolbox VI"
    )
    for side in sizes:
        t0 = time.perf_counter()
        domain = GridWorld.from_grid(open_grid(side, side), discount=DISCOUNT, noise=0.3)
        t1 = time.perf_counter()
        model = domain.model()
        t2 = time.perf_counter()
        _ = model.stacked_transitions, model.state_major_transitions
        plain_time, _, plain_values = plain_scipy_vi(model)
        vi = ValueIteration(tolerance=TOLERANCE).plan(model)
        assert np.allclose(vi.values, plain_values, atol=1e-4)
        if model.num_states <= 100_000:
            pi = PolicyIteration().plan(model)
            pi_text = f"{pi.wall_time_s:10.2f}s {pi.iterations:>8}"
        else:
            pi_text = f"{'(skipped)':>11} {'':>8}"
        print(
            f"{model.num_states:>9,} {t1 - t0:6.2f}s {t2 - t1:6.2f}s {plain_time:8.2f}s "
            f"{vi.wall_time_s:10.2f}s {vi.iterations:>6} {pi_text}  {mdptoolbox_vi(model)}"
        )


def lspi(num_samples=100_000):
    spec = DomainSpec(
        name="box",
        low=[0.0, 0.0],
        high=[1.0, 1.0],
        is_discrete=[False, False],
        num_actions=3,
        discount=0.95,
        max_episode_steps=100,
    )
    rng = np.random.default_rng(0)
    states = rng.random((num_samples, 2))
    nexts = np.clip(states + rng.normal(scale=0.05, size=states.shape), 0, 1)
    actions = rng.integers(3, size=num_samples)
    batch = [
        Transition(s, int(a), float(s[0] > 0.9), n, int(rng.integers(3)), False)
        for s, a, n in zip(states, actions, nexts, strict=True)
    ]
    agent = LSPI(representation=TileCoding(num_tilings=8, tiles_per_dim=20), max_iterations=5)
    agent.setup(spec, seed=0)
    started = time.perf_counter()
    agent.fit(batch)
    total = time.perf_counter() - started
    print(
        f"LSPI: {num_samples:,} samples, {agent.num_features:,} features x 3 actions "
        f"(8 active per state): {agent.iterations_} iterations in {total:.2f} s "
        f"({total / agent.iterations_:.2f} s per iteration incl. one-off encoding)"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 316, 1000])
    parser.add_argument("--skip-lspi", action="store_true")
    args = parser.parse_args()
    planning(args.sizes)
    if not args.skip_lspi:
        lspi()
