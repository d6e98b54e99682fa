"""A safety-gymnasium-style corridor whose cost does not end the episode (tests import it).

Cells 0..4, start 1, goal 4 (reward 1, terminal); entering or staying in cell 0 costs
``cost_value`` without ending the episode. Its ``step`` returns six values, (obs, reward,
cost, terminated, truncated, info), and it counts the costs it reported in
``costs_reported``.
"""

import gymnasium as gym

#: The id `register` gives the corridor (20 steps per episode).
CORRIDOR_ID = "ConjureTestHazard-v0"


class HazardCorridor(gym.Env):
    """Cells 0..4: action 1 moves right, 0 left; cell 0 costs, cell 4 is the goal."""

    def __init__(self, cost_value=1.0):
        self.observation_space = gym.spaces.Discrete(5)
        self.action_space = gym.spaces.Discrete(2)
        self.cost_value = cost_value
        self.costs_reported = 0.0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.cell = 1
        return self.cell, {}

    def step(self, action):
        self.cell = min(max(self.cell + (1 if action == 1 else -1), 0), 4)
        cost = self.cost_value if self.cell == 0 else 0.0
        self.costs_reported += cost if isinstance(cost, float) else 0.0
        return self.cell, float(self.cell == 4), cost, self.cell == 4, False, {}


def register() -> str:
    """Register the corridor with Gymnasium (once) and return its id."""
    if CORRIDOR_ID not in gym.registry:
        gym.register(id=CORRIDOR_ID, entry_point=HazardCorridor, max_episode_steps=20)
    return CORRIDOR_ID
