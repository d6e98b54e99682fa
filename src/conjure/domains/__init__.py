"""Domains: the MDPs conjure learns on, each a `gymnasium.Env` with a `DomainSpec`.

Importing ``conjure`` (so this package too) registers the conjure domains with Gymnasium, so
that ``gymnasium.make("conjure/InvertedPendulum-v0")`` works: the ids are listed once, in
`conjure.environments`.
"""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "BlocksWorld": "blocksworld",
    "ChainMDP": "chain",
    "GridWorld": "gridworld",
    "GymnasiumDomain": "gymnasium_adapter",
    "from_gymnasium": "gymnasium_adapter",
    "InvertedPendulum": "pendulum",
    "PersistentSurveillance": "persistent_surveillance",
    "RescueMission": "rescue_mission",
    "UAVMission": "uav_mission",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
