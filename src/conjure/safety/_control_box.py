"""Setting up iCCA's control box around T̂ (Geramifard 2012, Section 5.2, Figure 5-11)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.interfaces import DomainSpec
from conjure.models.approximate_model import ApproximateModel


def set_up_control_box(
    spec: DomainSpec,
    seeds: Mapping[str, int | np.random.SeedSequence],
    model: ApproximateModel,
    planner: CooperativePlanner,
    risk: RiskAnalyzer | None = None,
) -> tuple[ApproximateModel, CooperativePlanner, Any]:
    """Clone and set up T̂ → π^p planned on it → the risk analyser judging with both.

    Each part gets ``seeds[name]`` (``"model"``, ``"planner"``, ``"risk"``); the parameters are
    left as given (scikit-learn's lifecycle). Return (model_, planner_, risk_), risk_ ``None``
    without ``risk`` (a planner alone, `PlannerAgent`).
    """
    model_ = model.clone().setup(spec, seeds["model"])
    planner_ = planner.clone().setup(model_, seeds["planner"])
    risk_ = None if risk is None else risk.clone().setup(model_, planner_, seeds["risk"])
    return model_, planner_, risk_
