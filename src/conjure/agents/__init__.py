"""Learners: Q-Learning, SARSA(λ), Actor-Critic (Algorithms 10-12); LSTD, LSPI, LSPI-BRM (14-15)."""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "ActorCritic": "actor_critic",
    "FDLSTD": "fdlstd",
    "LinearTDAgent": "linear_td",
    "LSPI": "lspi",
    "LSPIBRM": "lspi_brm",
    "LSTD": "lstd",
    "QLearning": "q_learning",
    "SARSA": "sarsa",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
