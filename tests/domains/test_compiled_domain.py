"""Each domain's compiled form steps as its Python ``step`` does: same states, rewards, draws."""

import numpy as np
import pytest

from conjure.domains import (
    BlocksWorld,
    ChainMDP,
    GridWorld,
    InvertedPendulum,
    PersistentSurveillance,
    RescueMission,
    UAVMission,
)
from conjure.domains.compiled_domain import legal_into, reset_into, step_into

DOMAINS = {
    "pendulum": lambda: InvertedPendulum(force_noise=10.0, start_noise=0.1),
    "gridworld": lambda: GridWorld.gridworld_1(noise=0.3),
    "chain": lambda: ChainMDP(num_states=5, num_actions=2, slip=0.3),
    "blocks": lambda: BlocksWorld(num_blocks=4, drop_probability=0.3),
    "pst": PersistentSurveillance,
    "rescue": RescueMission,
    "uav": lambda: UAVMission(traverse_failure=0.2),
}


def _python_rollout(domain, actions_rng, num_steps):
    rows = []
    obs, _ = domain.reset(seed=3)
    rows.append(("reset", obs.tolist()))
    for _ in range(num_steps):
        legal = domain.legal_actions(obs)
        action = int(actions_rng.choice(legal))
        obs, reward, terminated, _, info = domain.step(action)
        rows.append((action, obs.tolist(), reward, terminated, info.get("cost", 0.0)))
        if terminated:
            obs, _ = domain.reset()
            rows.append(("reset", obs.tolist()))
    return rows


def _kernel_rollout(domain, actions_rng, num_steps):
    rows = []
    obs, _ = domain.reset(seed=3)  # seeds np_random; the kernels draw from it from here on
    rows.append(("reset", obs.tolist()))
    form = domain.compiled_form()
    out = np.arange(domain.domain_spec.num_actions)
    buffer = obs.astype(np.float64).copy()
    for _ in range(num_steps):
        legal = legal_into(form, out.copy())
        action = int(actions_rng.choice(legal))
        reward, terminated, cost = step_into(form, action, buffer, domain.np_random)
        rows.append((action, buffer.tolist(), reward, terminated, cost))
        if terminated:
            reset_into(form, buffer, domain.np_random)
            rows.append(("reset", buffer.tolist()))
    return rows


@pytest.mark.parametrize("name", list(DOMAINS))
def test_the_kernels_step_as_the_python_domain(name):
    python = _python_rollout(DOMAINS[name](), np.random.default_rng(0), 300)
    compiled = _kernel_rollout(DOMAINS[name](), np.random.default_rng(0), 300)
    assert compiled == python


def _mixed_rollout(domain, actions_rng, num_steps):
    """Kernel steps and Python steps in turn, on one domain (resets alternate too)."""
    rows = []
    obs, _ = domain.reset(seed=3)
    rows.append(("reset", obs.tolist()))
    form = domain.compiled_form()
    out = np.arange(domain.domain_spec.num_actions)
    for k in range(num_steps):
        if k % 2:  # Python, after a kernel step: the legal actions read the domain's mask
            action = int(actions_rng.choice(domain.legal_actions(obs)))
            obs, reward, terminated, _, info = domain.step(action)
            cost = info.get("cost", 0.0)
        else:
            action = int(actions_rng.choice(legal_into(form, out.copy())))
            obs = obs.astype(np.float64)
            reward, terminated, cost = step_into(form, action, obs, domain.np_random)
        rows.append((action, obs.tolist(), reward, terminated, cost))
        if terminated and k % 2:
            obs = obs.astype(np.float64)
            assert reset_into(form, obs, domain.np_random)
            rows.append(("reset", obs.tolist()))
        elif terminated:
            obs, _ = domain.reset()
            rows.append(("reset", obs.tolist()))
    return rows


@pytest.mark.parametrize("name", list(DOMAINS))
def test_the_loop_and_step_share_the_domains_state(name):
    # The compiled form holds the domain's own state (and legal-action mask): kernel steps and
    # Python steps on one domain follow a Python-only twin, with nothing copied in or back.
    python = _python_rollout(DOMAINS[name](), np.random.default_rng(0), 300)
    assert _mixed_rollout(DOMAINS[name](), np.random.default_rng(0), 300) == python


def test_a_form_shares_the_grids_tables_and_holds_its_state():
    # Built once per `_build`: a form per `advance` costs no copy of a large map's tables,
    # and the loop steps the domain's own cell (nothing is loaded back).
    domain = GridWorld.gridworld_1()
    domain.reset(seed=0)
    first, second = domain.compiled_form(), domain.compiled_form()
    assert first.table is second.table and first.cells is second.cells
    first.state[0] = 5
    assert domain._cell == 5 and second.state[0] == 5
    domain.reset()
    assert first.state[0] == domain._start_cell


def test_a_form_names_its_domains_constants():
    from conjure.domains.compiled_domain import DomainKernel

    assert "params" not in DomainKernel._fields  # no positional slots
    form = PersistentSurveillance(num_uavs=2, max_fuel=7, crash_penalty=3.0).compiled_form()
    assert (form.pst.num_uavs, form.pst.max_fuel, form.pst.crash_penalty) == (2, 7, 3.0)
    form = BlocksWorld(num_blocks=4, drop_probability=0.3).compiled_form()
    assert (form.blocks.num_blocks, form.blocks.drop) == (4, 0.3)
    assert ChainMDP(num_states=5, slip=0.3).compiled_form().chain.slip == 0.3


def test_persistent_surveillance_has_one_start_state():
    from conjure.domains._uav_kernels import pst_start

    domain = PersistentSurveillance(num_uavs=2, max_fuel=7)
    state = np.full(8, -1, dtype=np.int64)
    pst_start(domain.compiled_form().pst, state)
    assert state.tolist() == domain.reset(seed=0)[0].tolist() == [7, 0, 1, 1] * 2
