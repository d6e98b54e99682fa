"""Online learners: Q-Learning, SARSA(λ) and Actor-Critic (Geramifard 2012, Algorithms 10-12)."""

from conjure.agents.actor_critic import ActorCritic
from conjure.agents.base import LinearTDAgent
from conjure.agents.q_learning import QLearning
from conjure.agents.sarsa import SARSA

__all__ = ["SARSA", "ActorCritic", "LinearTDAgent", "QLearning"]
