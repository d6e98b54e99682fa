import gymnasium as gym
import numpy as np
import pytest

from conjure.core.errors import InvalidParameterError
from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.safety import MonteCarloRiskAnalyzer, NominalRiskAnalyzer, SafetyShield

# Gymnasium's CliffWalking (4 x 12, start bottom left, goal bottom right, the cliff between):
# a conjure GridWorld of the same map, with the cliff as pits, is the shield's model.
CLIFF = np.zeros((4, 12), dtype=np.int64)
CLIFF[3, 0], CLIFF[3, 11], CLIFF[3, 1:11] = 2, 3, 4
# CliffWalking's actions are 0 up, 1 right, 2 down, 3 left; GridWorld's 0 up, 1 down, 2 left,
# 3 right.
CLIFF_TO_GRID = [0, 3, 1, 2]


def cliff_falls(env, num_steps=3000, seed=0):
    """Random actions; a fall is CliffWalking's -100 reward."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    falls = shielded = 0
    for _ in range(num_steps):
        _, reward, terminated, truncated, info = env.step(int(rng.integers(4)))
        falls += int(reward == -100)
        shielded += int(info.get("shielded", False))
        if terminated or truncated:
            env.reset()
    return falls, shielded


def shielded_cliff(risk):
    return SafetyShield(
        gym.make("CliffWalking-v1"),
        model=ApproximateModel(domain=GridWorld.from_grid(CLIFF, noise=0.0)),
        planner=ShortestPathPlanner(),
        risk=risk,
        observation_to_state=lambda s: np.array(divmod(int(s), 12), dtype=np.float64),
        action_map=CLIFF_TO_GRID,
    )


@pytest.mark.parametrize("risk", [NominalRiskAnalyzer(), MonteCarloRiskAnalyzer()])
def test_a_random_agent_never_falls_off_gymnasiums_cliff_when_shielded(risk):
    falls, _ = cliff_falls(gym.make("CliffWalking-v1"))
    assert falls > 50  # unshielded, it falls often
    falls, shielded = cliff_falls(shielded_cliff(risk))
    assert falls == 0 and shielded > 50


def test_the_replacement_is_the_planners_action_in_the_environments_numbering():
    env = shielded_cliff(NominalRiskAnalyzer())
    observation, _ = env.reset(seed=0)
    assert observation == 36  # (3, 0)
    _, reward, _, _, info = env.step(1)  # right: off the cliff
    assert info["shielded"] and info["executed_action"] == 0  # up, CliffWalking's numbering
    assert reward == -1 and env.num_shielded_ == 1


def test_conjure_domains_need_no_translation():
    env = SafetyShield(
        GridWorld.gridworld_1(noise=0.0),
        model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
        planner=ShortestPathPlanner(),
        risk=NominalRiskAnalyzer(),
    )
    env.reset(seed=0)
    env.step(1)  # down to (1, 0), above the pit
    _, _, terminated, _, info = env.step(1)
    assert info["shielded"] and not terminated


def test_misuse_is_refused():
    model = ApproximateModel(domain=GridWorld.from_grid(CLIFF, noise=0.0))
    kwargs = {"model": model, "planner": ShortestPathPlanner(), "risk": NominalRiskAnalyzer()}
    with pytest.raises(InvalidParameterError, match="permutation"):
        SafetyShield(gym.make("CliffWalking-v1"), action_map=[0, 1, 1, 2], **kwargs)
    with pytest.raises(InvalidParameterError, match="risk"):
        SafetyShield(gym.make("CliffWalking-v1"), **{**kwargs, "risk": "safe"})
    with pytest.raises(gym.error.ResetNeeded):
        SafetyShield(GridWorld.from_grid(CLIFF), **kwargs).step(0)


def test_the_planner_is_asked_once_per_step():
    # Issue 22: the shield asked π^p inside `is_safe` and again for the replacement.
    from safety_fakes import CountingPlanner

    shield = SafetyShield(
        GridWorld.gridworld_1(noise=0.0),
        model=ApproximateModel(domain=GridWorld.gridworld_1(noise=0.0)),
        planner=CountingPlanner(planner=ShortestPathPlanner()),
        risk=NominalRiskAnalyzer(),
    )
    shield.reset(seed=0)
    for action in (1, 1, 3):  # down, then down into the pit (shielded), then right
        before = shield.planner_.num_actions_
        shield.step(action)
        assert shield.planner_.num_actions_ == before + 1
    assert shield.num_shielded_ == 1
