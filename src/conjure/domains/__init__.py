"""Domains: the MDPs conjure learns on, each a `gymnasium.Env` with a `DomainSpec`.

Importing ``conjure`` (so this package too) registers the conjure domains with Gymnasium, so
that ``gymnasium.make("conjure/InvertedPendulum-v0")`` works: the ids are listed once, in
`conjure.environments`.
"""

from __future__ import annotations

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
