"""The conjure domains as Gymnasium environments: the one table of ids, registered on import.

``import conjure`` calls `register_environments`, so ``gymnasium.make("conjure/GridWorld1-v0")``
works after it (Gymnasium has no plugin discovery). Entry points are strings: this module
imports no domain code, and Gymnasium imports a domain's module when the environment is made.

Add an environment with one line in `ENVIRONMENTS`: ``(id, entry point, max_episode_steps,
keyword arguments)``.

Notes
-----
- The UAV missions' v0 ids keep spec 2.2's first reconstructions ("uav-7-2-spec",
  "uav-10-2-spec"); v1 ids are the calibrated graphs, the defaults.
  Gymnasium warns that a v0 id "is out of date" when made: the v1 graph is the one to use
  unless reproducing results of the first reconstruction.
- Choice: registration skips ids already registered, so importing or calling it again is
  harmless (Gymnasium warns when an id is registered twice).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

__all__ = ["ENVIRONMENTS", "register_environments"]

# fmt: off
#: Every conjure environment: (id, entry point, max_episode_steps, keyword arguments).
ENVIRONMENTS: tuple[tuple[str, str, int, dict[str, Any]], ...] = (
    ("conjure/InvertedPendulum-v0", "conjure.domains.pendulum:InvertedPendulum", 3000, {}),
    ("conjure/GridWorld-v0", "conjure.domains.gridworld:GridWorld", 1000, {}),
    ("conjure/GridWorld1-v0", "conjure.domains.gridworld:GridWorld", 1000, {"map_name": "gridworld1", "step_reward": -0.001, "noise": 0.3}),  # noqa: E501
    ("conjure/GridWorld2-v0", "conjure.domains.gridworld:GridWorld", 1000, {"map_name": "gridworld2", "step_reward": -0.01, "noise": 0.2}),  # noqa: E501
    ("conjure/GridWorld3-v0", "conjure.domains.gridworld:GridWorld", 1000, {"map_name": "gridworld3", "step_reward": -0.01, "noise": 0.55, "noise_cells": "windy"}),  # noqa: E501
    ("conjure/ChainMDP-v0", "conjure.domains.chain:ChainMDP", 100, {}),
    ("conjure/BlocksWorld-v0", "conjure.domains.blocksworld:BlocksWorld", 1000, {}),
    ("conjure/PersistentSurveillance-v0", "conjure.domains.persistent_surveillance:PersistentSurveillance", 1000, {}),  # noqa: E501
    ("conjure/RescueMission-v0", "conjure.domains.rescue_mission:RescueMission", 10, {}),
    ("conjure/UAV-7-2-v0", "conjure.domains.uav_mission:UAVMission", 8, {"scenario": "uav-7-2-spec"}),  # noqa: E501
    ("conjure/UAV-10-2-v0", "conjure.domains.uav_mission:UAVMission", 11, {"scenario": "uav-10-2-spec"}),  # noqa: E501
    ("conjure/UAV-7-2-v1", "conjure.domains.uav_mission:UAVMission", 8, {"scenario": "uav-7-2"}),
    ("conjure/UAV-10-2-v1", "conjure.domains.uav_mission:UAVMission", 11, {"scenario": "uav-10-2"}),
)
# fmt: on


def register_environments() -> None:
    """Register every environment of `ENVIRONMENTS` with Gymnasium (ids present are skipped).

    Examples
    --------
    >>> import gymnasium
    >>> register_environments()
    >>> gymnasium.spec("conjure/ChainMDP-v0").entry_point
    'conjure.domains.chain:ChainMDP'
    """
    for env_id, entry_point, max_episode_steps, kwargs in ENVIRONMENTS:
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry_point,
                max_episode_steps=max_episode_steps,
                kwargs=kwargs,
            )
