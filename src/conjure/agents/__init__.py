"""Learners: Q-Learning, SARSA(λ), Actor-Critic (Algorithms 10-12); LSTD, LSPI, LSPI-BRM (14-15)."""

from conjure.agents.actor_critic import ActorCritic
from conjure.agents.fdlstd import FDLSTD
from conjure.agents.linear_td import LinearTDAgent
from conjure.agents.lspi import LSPI
from conjure.agents.lspi_brm import LSPIBRM
from conjure.agents.lstd import LSTD
from conjure.agents.q_learning import QLearning
from conjure.agents.sarsa import SARSA

__all__ = [
    "FDLSTD",
    "LSPI",
    "LSPIBRM",
    "LSTD",
    "SARSA",
    "ActorCritic",
    "LinearTDAgent",
    "QLearning",
]
