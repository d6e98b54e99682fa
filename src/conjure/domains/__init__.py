"""Domains: the MDPs conjure learns on, each a `gymnasium.Env` with a `DomainSpec`.

Importing this package registers the conjure domains with Gymnasium, so that
``gymnasium.make("conjure/InvertedPendulum-v0")`` works (Gymnasium has no plugin discovery).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from conjure.domains.blocksworld import BlocksWorld
from conjure.domains.chain import ChainMDP
from conjure.domains.gridworld import GridWorld
from conjure.domains.gymnasium_adapter import GymnasiumDomain, from_gymnasium
from conjure.domains.pendulum import InvertedPendulum
from conjure.domains.persistent_surveillance import PersistentSurveillance
from conjure.domains.rescue_mission import RescueMission
from conjure.domains.uav_mission import UAVMission

__all__ = [
    "BlocksWorld",
    "ChainMDP",
    "GridWorld",
    "GymnasiumDomain",
    "InvertedPendulum",
    "PersistentSurveillance",
    "RescueMission",
    "UAVMission",
    "from_gymnasium",
]

# (id, entry point, max_episode_steps, kwargs)
_REGISTRATIONS: tuple[tuple[str, str, int, dict[str, Any]], ...] = (
    ("conjure/InvertedPendulum-v0", "conjure.domains.pendulum:InvertedPendulum", 3000, {}),
    ("conjure/GridWorld-v0", "conjure.domains.gridworld:GridWorld", 1000, {}),
    (
        "conjure/GridWorld1-v0",
        "conjure.domains.gridworld:GridWorld",
        1000,
        {"map_name": "gridworld1", "step_reward": -0.001, "noise": 0.3},
    ),
    (
        "conjure/GridWorld2-v0",
        "conjure.domains.gridworld:GridWorld",
        1000,
        {"map_name": "gridworld2", "step_reward": -0.01, "noise": 0.2},
    ),
    ("conjure/ChainMDP-v0", "conjure.domains.chain:ChainMDP", 100, {}),
    ("conjure/BlocksWorld-v0", "conjure.domains.blocksworld:BlocksWorld", 1000, {}),
    (
        "conjure/PersistentSurveillance-v0",
        "conjure.domains.persistent_surveillance:PersistentSurveillance",
        1000,
        {},
    ),
    ("conjure/RescueMission-v0", "conjure.domains.rescue_mission:RescueMission", 10, {}),
    (
        "conjure/UAV-7-2-v0",
        "conjure.domains.uav_mission:UAVMission",
        8,
        {"scenario": "uav-7-2"},
    ),
    (
        "conjure/UAV-10-2-v0",
        "conjure.domains.uav_mission:UAVMission",
        11,
        {"scenario": "uav-10-2"},
    ),
)


def _register_with_gymnasium() -> None:
    """Register every conjure domain with Gymnasium once (re-imports are harmless)."""
    for env_id, entry_point, max_episode_steps, kwargs in _REGISTRATIONS:
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry_point,
                max_episode_steps=max_episode_steps,
                kwargs=kwargs,
            )


_register_with_gymnasium()
