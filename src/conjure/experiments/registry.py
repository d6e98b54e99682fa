"""Component registries: one table per layer, one line per component (STYLE §3).

A config names a component by its ``kind`` (the class name; ``Gymnasium`` for
`GymnasiumDomain`) and gives its ``params``; a parameter whose value is itself a component is
written as a nested ``{kind, params}``. Kinds are unique across layers, so a nested kind is
looked up in every registry.

Notes
-----
- Choice: no import-time registration decorators; to add a component, add one line here.
- Choice: a line names the class by its import path (``"conjure.agents:SARSA"``) and the class
  is imported when a config first names it, so a SARSA run never imports the batch learners,
  the planners or SciPy (start-up time and memory).
"""

from __future__ import annotations

import importlib
import inspect
import re
from collections.abc import Iterator, Mapping, MutableMapping
from typing import Any

import numpy as np

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Configurable, did_you_mean

__all__ = [
    "AGENTS",
    "CONSTRAINTS",
    "COOPERATIVE_PLANNERS",
    "DOMAINS",
    "LAYERS",
    "MODELS",
    "PLANNERS",
    "POLICIES",
    "REPRESENTATIONS",
    "RISK_ANALYZERS",
    "SCHEDULES",
    "build",
    "find_kind",
    "kind_of",
    "to_spec",
]


class Registry(MutableMapping[str, type[Configurable]]):
    """One layer's components by kind; each class is imported when it is first looked up.

    Entries are ``"package:ClassName"`` paths or classes (tests and users may add classes).

    Examples
    --------
    >>> table = Registry({"SARSA": "conjure.agents:SARSA"})
    >>> table.class_name("SARSA"), table["SARSA"].__module__
    ('SARSA', 'conjure.agents.sarsa')
    """

    def __init__(self, entries: Mapping[str, str | type[Configurable]]):
        self._entries = dict(entries)

    def __getitem__(self, kind: str) -> type[Configurable]:
        entry = self._entries[kind]
        if isinstance(entry, str):
            package, name = entry.split(":")
            entry = self._entries[kind] = getattr(importlib.import_module(package), name)
        return entry

    def __setitem__(self, kind: str, cls: type[Configurable]) -> None:
        self._entries[kind] = cls

    def __delitem__(self, kind: str) -> None:
        del self._entries[kind]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def copy(self) -> Registry:
        """A registry with the same entries (classes stay unimported until looked up)."""
        return Registry(self._entries)

    def class_name(self, kind: str) -> str:
        """The name of the class registered as ``kind``, without importing it."""
        entry = self._entries[kind]
        return entry.rsplit(":", 1)[1] if isinstance(entry, str) else entry.__name__


DOMAINS = Registry(
    {
        "BlocksWorld": "conjure.domains:BlocksWorld",
        "ChainMDP": "conjure.domains:ChainMDP",
        "GridWorld": "conjure.domains:GridWorld",
        "Gymnasium": "conjure.domains:GymnasiumDomain",
        "InvertedPendulum": "conjure.domains:InvertedPendulum",
        "PersistentSurveillance": "conjure.domains:PersistentSurveillance",
        "RescueMission": "conjure.domains:RescueMission",
        "UAVMission": "conjure.domains:UAVMission",
    }
)
REPRESENTATIONS = Registry(
    {
        "ARiFDD": "conjure.representations:ARiFDD",
        "AdaptiveTileCoding": "conjure.representations:AdaptiveTileCoding",
        "BinaryIndicators": "conjure.representations:BinaryIndicators",
        "HashedTabular": "conjure.representations:HashedTabular",
        "IndependentDiscretization": "conjure.representations:IndependentDiscretization",
        "OnlineIFDD": "conjure.representations:OnlineIFDD",
        "RandomExpansion": "conjure.representations:RandomExpansion",
        "RBF": "conjure.representations:RBF",
        "SparseDistributedMemory": "conjure.representations:SparseDistributedMemory",
        "Tabular": "conjure.representations:Tabular",
        "TileCoding": "conjure.representations:TileCoding",
    }
)
POLICIES = Registry(
    {
        "EpsilonGreedy": "conjure.policies:EpsilonGreedy",
        "Gibbs": "conjure.policies:Gibbs",
    }
)
AGENTS = Registry(
    {
        "ActorCritic": "conjure.agents:ActorCritic",
        "AdaptiveCooperativeLearner": "conjure.safety:AdaptiveCooperativeLearner",
        "CooperativeActorCritic": "conjure.safety:CooperativeActorCritic",
        "CooperativeLearner": "conjure.safety:CooperativeLearner",
        "FDLSTD": "conjure.agents:FDLSTD",
        "LSPI": "conjure.agents:LSPI",
        "LSPIBRM": "conjure.agents:LSPIBRM",
        "LSTD": "conjure.agents:LSTD",
        "PlannerAgent": "conjure.safety:PlannerAgent",
        "QLearning": "conjure.agents:QLearning",
        "SARSA": "conjure.agents:SARSA",
        "ShieldedLearner": "conjure.safety:ShieldedLearner",
    }
)
PLANNERS = Registry(
    {
        "FittedValueIteration": "conjure.planners:FittedValueIteration",
        "PolicyIteration": "conjure.planners:PolicyIteration",
        "QAPI": "conjure.planners:QAPI",
        "QAVI": "conjure.planners:QAVI",
        "SampledQAPI1": "conjure.planners:SampledQAPI1",
        "SampledQAPI2": "conjure.planners:SampledQAPI2",
        "SampledQAVI": "conjure.planners:SampledQAVI",
        "TrajectoryQAPI": "conjure.planners:TrajectoryQAPI",
        "VAPI": "conjure.planners:VAPI",
        "ValueIteration": "conjure.planners:ValueIteration",
    }
)
#: π^p of iCCA (Section 5.3.1): `conjure.core.cooperative.CooperativePlanner` subclasses.
COOPERATIVE_PLANNERS = Registry(
    {
        "CBBAPlanner": "conjure.planners:CBBAPlanner",
        "ModelPlanner": "conjure.planners:ModelPlanner",
        "ShortestPathPlanner": "conjure.planners:ShortestPathPlanner",
        "SwitchingPlanner": "conjure.planners:SwitchingPlanner",
    }
)
RISK_ANALYZERS = Registry(
    {
        "FuelRiskAnalyzer": "conjure.safety:FuelRiskAnalyzer",
        "MonteCarloRiskAnalyzer": "conjure.safety:MonteCarloRiskAnalyzer",
        "NominalRiskAnalyzer": "conjure.safety:NominalRiskAnalyzer",
    }
)
MODELS = Registry(
    {
        "ApproximateModel": "conjure.models.approximate_model:ApproximateModel",
    }
)
SCHEDULES = Registry(
    {
        "ConstantStepSize": "conjure.core.schedules:ConstantStepSize",
        "EpisodicDecay": "conjure.core.schedules:EpisodicDecay",
        "FeatureNormalizedDecay": "conjure.core.schedules:FeatureNormalizedDecay",
    }
)
#: Cost constraints of the linear TD learners (`conjure.agents.constraints`).
CONSTRAINTS = Registry(
    {
        "Lagrangian": "conjure.agents.constraints:Lagrangian",
        "PIDLagrangian": "conjure.agents.constraints:PIDLagrangian",
    }
)

#: Every registry by layer name (the ``layer`` argument of `build`).
LAYERS: dict[str, Registry] = {
    "domain": DOMAINS,
    "representation": REPRESENTATIONS,
    "policy": POLICIES,
    "agent": AGENTS,
    "planner": PLANNERS,
    "cooperative_planner": COOPERATIVE_PLANNERS,
    "risk": RISK_ANALYZERS,
    "model": MODELS,
    "schedule": SCHEDULES,
    "constraint": CONSTRAINTS,
}


def find_kind(kind: str, layer: str | None = None, *, path: str = "") -> type[Configurable]:
    """Return the class registered as ``kind`` (in ``layer``, or in any layer if ``None``).

    ``kind`` matches case-insensitively when exactly one class has that name in any case.

    Examples
    --------
    >>> find_kind("Sarsa", "agent").__name__
    'SARSA'
    """
    where = f"{path}: " if path else ""
    if layer is not None and layer not in LAYERS:
        raise InvalidParameterError(
            f"Unknown layer {layer!r}.{did_you_mean(layer, LAYERS)} Known: {', '.join(LAYERS)}."
        )
    registries = [LAYERS[layer]] if layer is not None else list(LAYERS.values())
    if not isinstance(kind, str):
        raise InvalidParameterError(f"{where}`kind` must be a component name; got {kind!r}.")
    for registry in registries:
        if kind in registry:
            return registry[kind]
    known = sorted(k for registry in registries for k in registry)
    # Choice: kinds match case-insensitively when that names one class ("Sarsa" is SARSA);
    # the resolved config records the registered spelling.
    same = {registry[k] for registry in registries for k in registry if k.lower() == kind.lower()}
    if len(same) == 1:
        return same.pop()
    noun = f"{layer} kind" if layer is not None else "kind"
    raise InvalidParameterError(
        f"{where}unknown {noun} {kind!r}.{did_you_mean(kind, known)} Known: {', '.join(known)}."
    )


def _is_component_spec(value: Any) -> bool:
    return isinstance(value, Mapping) and "kind" in value and set(value) <= {"kind", "params"}


def build(layer: str | None, spec: Mapping[str, Any], *, path: str = "") -> Configurable:
    """Build a component from ``{kind, params}``, building nested ``{kind, params}`` values.

    Parameters
    ----------
    layer : str or None
        A key of `LAYERS` (``"domain"``, ``"agent"``, ``"cooperative_planner"``, ...);
        ``None`` looks the kind up in every registry.
    spec : mapping
        ``{"kind": name, "params": {...}}`` (``params`` may be omitted).
    path : str, default ""
        Where ``spec`` sits in the config (``agents.tile.params``), prefixed to error messages.

    Returns
    -------
    Configurable
        The component, with validated parameters (not set up).

    Raises
    ------
    InvalidParameterError
        For an unknown kind or parameter (with a did-you-mean suggestion), a missing required
        parameter, or a value that breaks the component's declared constraints.
    """
    where = path or (layer or "component")
    if not isinstance(spec, Mapping) or "kind" not in spec:
        raise InvalidParameterError(
            f"{where}: a component must be a mapping {{kind: Name, params: {{...}}}}; got {spec!r}."
        )
    extra = set(spec) - {"kind", "params"}
    if extra:
        name = sorted(extra)[0]
        raise InvalidParameterError(
            f"{where}: unexpected key {name!r}.{did_you_mean(name, ['kind', 'params'])} "
            f"A component has only `kind` and `params`."
        )
    cls = find_kind(spec["kind"], layer, path=f"{where}.kind")
    params = spec.get("params") or {}
    if not isinstance(params, Mapping):
        raise InvalidParameterError(f"{where}.params must be a mapping; got {params!r}.")
    known = cls.param_names()
    built: dict[str, Any] = {}
    for name, value in params.items():
        if name not in known:
            raise InvalidParameterError(
                f"{where}.params: {cls.__name__} has no parameter {name!r}."
                f"{did_you_mean(str(name), known)} Known: {', '.join(known)}."
            )
        built[name] = _build_value(value, f"{where}.params.{name}")
    defaults = cls.param_defaults()
    missing = [n for n in known if n not in built and defaults[n] is inspect.Parameter.empty]
    if missing:
        raise InvalidParameterError(
            f"{where}.params: `{cls.__name__}.{missing[0]}` is required but was not given."
        )
    try:
        component = cls(**built)
    except InvalidParameterError as exc:  # domains validate in their constructor
        named = re.search(rf"`{cls.__name__}\.(\w+)`", str(exc))
        field = f"{where}.params.{named.group(1)}" if named else f"{where}.params"
        raise InvalidParameterError(f"{field}: {exc}") from exc
    except TypeError as exc:  # a constructor that rejects its arguments
        raise InvalidParameterError(f"{where}: cannot build {cls.__name__}: {exc}") from exc
    try:
        component.validate_params()
    except InvalidParameterError as exc:
        bad = [
            name
            for name, constraint in cls.parameter_constraints.items()
            if not constraint.is_satisfied_by(getattr(component, name, None))
        ]
        field = f"{where}.params.{bad[0]}" if bad else f"{where}.params"
        raise InvalidParameterError(f"{field}: {exc}") from exc
    return component


def _build_value(value: Any, path: str) -> Any:
    if _is_component_spec(value):
        return build(None, value, path=path)
    if isinstance(value, list):
        return [_build_value(v, f"{path}[{i}]") for i, v in enumerate(value)]
    return value


def kind_of(component: Configurable) -> str:
    """Return the registry name of ``component``'s class (its class name if unregistered)."""
    cls = type(component)
    for registry in LAYERS.values():
        for kind in registry:
            if registry.class_name(kind) == cls.__name__ and registry[kind] is cls:
                return kind
    return cls.__name__


def to_spec(component: Configurable) -> dict[str, Any]:
    """Return ``{kind, params}`` with every parameter (defaults included), as plain YAML data.

    The inverse of `build`: ``build(None, to_spec(c)) == c``.
    """
    return {
        "kind": kind_of(component),
        "params": {name: to_plain(value) for name, value in component.get_params().items()},
    }


def to_plain(value: Any) -> Any:
    """Return ``value`` as plain YAML/JSON data (components as ``{kind, params}``)."""
    if isinstance(value, Configurable):
        return to_spec(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    return value
