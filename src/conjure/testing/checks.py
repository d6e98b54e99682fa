"""Common checks every conjure component must pass, shipped for users' own components.

Like Gymnasium's ``check_env`` and scikit-learn's ``check_estimator``: call
``check_component(instance)`` (or a single ``check_*``) on a domain, representation, policy,
agent, planner, cooperative planner or risk analyser. Each check raises ``AssertionError`` with
a message saying what broke. A class may declare known exceptions as
``expected_check_failures = {"check_name": "reason"}``.

Cooperative planners and risk analysers are checked on the first shipped setting they accept
(`cooperative_settings`: a 4×5 grid world with a pit, then a small UAV mission). Agents whose
``model`` parameter is an `ApproximateModel` (the cooperative learners) are checked on the
model's domain instead of the 4-state chain.
"""

from __future__ import annotations

import copy
import functools
import pickle
import tempfile
import warnings
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import numpy as np
from gymnasium.utils.env_checker import check_env
from numba import njit, typeof
from numba.experimental.structref import StructRefProxy

from conjure.core.compiled_form import compiled_form
from conjure.core.cooperative import CooperativePlanner, NoisyDomain, RiskAnalyzer
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError, NotSetUpError
from conjure.core.interfaces import Agent, Domain, DomainSpec, Policy, Representation, Transition
from conjure.core.params import AnyOf, Configurable, Constraint, Options
from conjure.core.seeding import make_rng
from conjure.domains import GridWorld, UAVMission
from conjure.domains.compiled_domain import CALLBACK, DomainKernel, callback_domain
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner, ShortestPathPlanner
from conjure.planners.base import Planner
from conjure.testing.planner_checks import (
    check_planner_matches_closed_form,
    check_planner_policy_is_greedy,
)

__all__ = [
    "CooperativeSetting",
    "applicable_checks",
    "box_spec",
    "check_component",
    "cooperative_settings",
    "sample_states",
]

Check = Callable[[Any], None]
_BAD_VALUE = "not-a-valid-value"


# ------------------------------------------------------------------------------ helpers


def sample_states(spec: DomainSpec, num_states: int, seed: int = 0) -> np.ndarray:
    """Draw states uniformly within the spec's bounds (discrete dimensions rounded)."""
    rng = make_rng(seed)
    states = rng.uniform(spec.low, spec.high, size=(num_states, spec.num_dims))
    states[:, spec.is_discrete] = np.round(states[:, spec.is_discrete])
    return states


def box_spec(
    low: list[float],
    high: list[float],
    is_discrete: list[bool] | None = None,
    name: str = "box",
    num_actions: int = 3,
) -> DomainSpec:
    """A `DomainSpec` over the box [low, high] (continuous unless ``is_discrete`` says), γ 0.9.

    Examples
    --------
    >>> box_spec([0.0, -1.0], [1.0, 1.0]).num_dims
    2
    """
    return DomainSpec(
        name=name,
        low=low,
        high=high,
        is_discrete=[False] * len(low) if is_discrete is None else is_discrete,
        num_actions=num_actions,
        discount=0.9,
        max_episode_steps=10,
    )


def _check_spec() -> DomainSpec:
    """A 2-D spec every representation accepts: one binary and one continuous unit dimension."""
    return DomainSpec(
        name="checks",
        low=[0.0, 0.0],
        high=[1.0, 1.0],
        is_discrete=[True, False],
        num_actions=2,
        discount=0.9,
        max_episode_steps=50,
    )


#: Policy checks per `_rollout`: the agent's ``before_policy_check`` runs this many times.
NUM_ROLLOUT_CHECKS = 10


def _rollout(domain: Domain, agent: Agent, num_steps: int, seed: int) -> None:
    """A minimal learning loop (the experiments layer's loop is not importable here).

    As the run loop, it calls ``agent.before_policy_check()`` at `NUM_ROLLOUT_CHECKS` evenly
    spaced steps (the last one at ``num_steps``), where batch learners fit.
    """
    spec = domain.domain_spec
    checks = {num_steps * i // NUM_ROLLOUT_CHECKS for i in range(1, NUM_ROLLOUT_CHECKS + 1)}
    steps, episode = 0, 0
    while steps < num_steps:
        state, _ = domain.reset(seed=seed + episode)
        episode += 1
        agent.begin_episode()
        action = agent.act(state)
        for _ in range(spec.max_episode_steps):
            next_state, reward, terminated, truncated, _ = domain.step(action)
            next_action = 0 if terminated else agent.act(next_state)
            agent.learn(Transition(state, action, reward, next_state, next_action, terminated))
            steps += 1
            if steps in checks:
                agent.before_policy_check()
            if terminated or truncated or steps >= num_steps:
                break
            state, action = next_state, next_action


def _check_domain_for(agent: Agent) -> Domain:
    """The 4-state chain, or the model's domain for agents built around an `ApproximateModel`."""
    from conjure.domains import ChainMDP

    model = getattr(agent, "model", None)
    if isinstance(model, ApproximateModel):
        return model.domain.clone()
    return ChainMDP(num_states=4, num_actions=2, slip=0.1)


def _visited_states(domain: Domain, num_steps: int, seed: int = 0) -> list[np.ndarray]:
    """The states a random rollout of ``domain`` visits (valid states of any domain)."""
    records = _domain_rollout(domain, seed=seed, num_steps=num_steps)
    return [np.array(record[1]) for record in records]  # ("reset", s) or (a, s', r, ...)


# ------------------------------------------------------------------------------ cooperative parts


class CooperativeSetting(NamedTuple):
    """A model, a planner for it and an action known to be unsafe, for the iCCA checks."""

    domain: NoisyDomain
    planner: CooperativePlanner
    unsafe_state: np.ndarray
    unsafe_action: int

    def model(self) -> ApproximateModel:
        """A set-up `ApproximateModel` of the setting's domain."""
        return ApproximateModel(domain=self.domain).setup(self.domain.domain_spec, seed=0)


def cooperative_settings() -> list[CooperativeSetting]:
    """The settings cooperative planners and risk analysers are checked on, in order.

    A 4×5 grid world (noise 0.1, pit at (2, 2); moving left from (2, 3) enters it) and a
    4-node UAV line mission with aggressive CBBA (`line_mission`; UAV 1 at node 1 with 1 fuel
    flying on to node 2 cannot get home).
    """
    grid = GridWorld(map_name="4x5", noise=0.1, max_episode_steps=50)
    mission = UAVMission(graph=line_mission(), traverse_failure=0.05)
    stranded = mission.graph_.initial_state()
    stranded[0], stranded[1], stranded[-1] = 1.0, 1.0, 1.0
    return [
        CooperativeSetting(
            domain=grid,
            planner=ShortestPathPlanner(),
            unsafe_state=np.array([2.0, 3.0]),
            unsafe_action=2,
        ),
        CooperativeSetting(
            domain=mission,
            planner=CBBAPlanner(variant="aggressive"),
            unsafe_state=stranded,
            unsafe_action=mission.graph_.encode_action([2, 0]),
        ),
    ]


def line_mission() -> dict[str, Any]:
    """A 4-node line 0 - 1 - 2 - 3 (base 0), two UAVs with fuel 4, horizon 6, targets at 2, 3."""
    return {
        "num_nodes": 4,
        "edges": [[0, 1], [1, 2], [2, 3]],
        "fuel": [4, 4],
        "horizon": 6,
        "targets": {2: {"reward": 10.0, "probability": 0.5}, 3: {"reward": 20.0}},
    }


def _set_up_on_setting(component: CooperativePlanner | RiskAnalyzer, seed: int) -> tuple:
    """(set-up component, setting, model) on the first setting the component accepts."""
    for setting in cooperative_settings():
        model = setting.model()
        try:
            if isinstance(component, RiskAnalyzer):
                planner = setting.planner.setup(model, seed=0)
                return component.clone().setup(model, planner, seed), setting, model
            return component.clone().setup(model, seed), setting, model
        except IncompatibleComponentsError:
            continue
    raise AssertionError(
        f"{type(component).__name__} accepts none of the shipped check settings "
        f"({', '.join(type(s.domain).__name__ for s in cooperative_settings())}); declare the "
        f"cooperative checks in expected_check_failures."
    )


def check_cooperative_planner_legal(planner: CooperativePlanner) -> None:
    """π^p(s) is a legal action (an int) in every non-failure state a rollout visits.

    Failure states (`Domain.is_constrained`: a pit, a crash) are terminal, so no agent asks
    π^p there.
    """
    planner_, setting, _ = _set_up_on_setting(planner, seed=0)
    for state in _visited_states(setting.domain, 60):
        if setting.domain.is_constrained(state):
            continue
        action = planner_.action(state)
        assert isinstance(action, int), f"action() must return an int; got {action!r}."
        legal = setting.domain.legal_actions(state)
        assert action in legal, f"π^p({state.tolist()}) = {action} is not legal: {legal}."


def check_cooperative_planner_deterministic(planner: CooperativePlanner) -> None:
    """The same seed gives the same π^p; updating on an unchanged model changes nothing."""
    first, setting, model = _set_up_on_setting(planner, seed=5)
    second, _, _ = _set_up_on_setting(planner, seed=5)
    states = _visited_states(setting.domain, 60)
    actions = [first.action(s) for s in states]
    assert actions == [second.action(s) for s in states], "π^p differs for one seed."
    assert first.update(model) is False, "update() on an unchanged model reported a change."
    assert actions == [first.action(s) for s in states], "update() on the same model moved π^p."


def check_risk_planner_actions_safe(analyser: RiskAnalyzer) -> None:
    """The planner's own actions are judged safe (Section 5.5.1)."""
    analyser_, setting, _ = _set_up_on_setting(analyser, seed=0)
    for state in _visited_states(setting.domain, 60):
        if not setting.domain.is_constrained(state):
            action = analyser_.planner_.action(state)
            assert analyser_.is_safe(state, action), (
                f"The planner's action {action} in {state.tolist()} was judged unsafe."
            )


def check_risk_flags_unsafe_action(analyser: RiskAnalyzer) -> None:
    """An action known to lead into a constrained state is unsafe, with a positive risk."""
    analyser_, setting, _ = _set_up_on_setting(analyser, seed=0)
    state, action = setting.unsafe_state, setting.unsafe_action
    risk = analyser_.risk(state, action)
    assert 0.0 < risk <= 1.0, f"risk{state.tolist(), action} = {risk}; expected in (0, 1]."
    assert not analyser_.is_safe(state, action), f"{state.tolist(), action} was judged safe."


def check_risk_deterministic(analyser: RiskAnalyzer) -> None:
    """The same seed gives the same risk estimates (Monte-Carlo analysers included)."""
    estimates = []
    for _ in range(2):
        analyser_, setting, _ = _set_up_on_setting(analyser, seed=3)
        states = _visited_states(setting.domain, 30)
        estimates.append(
            [
                analyser_.risk(s, int(a))
                for s in states
                if not setting.domain.is_constrained(s)
                for a in setting.domain.legal_actions(s)[:4]
            ]
        )
    assert estimates[0] == estimates[1], "The risk estimates differ for one seed."


# ------------------------------------------------------------------------------ all components


def check_constructor_only_stores(component: Configurable) -> None:
    """The constructor stores each parameter unchanged and builds no learned state."""
    params = component.get_params()
    rebuilt = type(component)(**params)
    for name, value in params.items():
        assert getattr(rebuilt, name) is value, (
            f"{type(component).__name__}.__init__ changed parameter {name!r}; "
            f"constructors must store parameters unchanged."
        )
    if not isinstance(component, Domain):
        learned = [key for key in vars(rebuilt) if key.endswith("_")]
        assert not learned, f"{type(component).__name__}.__init__ set learned state {learned}."


def check_clone(component: Configurable) -> None:
    """``clone`` returns an equal, distinct component that is not set up."""
    twin = component.clone()
    assert twin is not component and twin == component, "clone() must return an equal copy."
    assert not getattr(twin, "is_set_up_", False), "clone() must return a component not set up."


def check_params_round_trip(component: Configurable) -> None:
    """``set_params(**get_params())`` leaves the parameters unchanged."""
    before = component.get_params()
    twin = component.clone()
    twin.set_params(**before)
    assert twin == component, "set_params(**get_params()) changed the component."


def check_bad_params_raise(component: Configurable) -> None:
    """Each declared parameter rejects a nonsense value with `InvalidParameterError`."""
    for name, constraint in component.parameter_constraints.items():
        if constraint.is_satisfied_by(_BAD_VALUE):
            continue
        params = {**component.clone().get_params(), name: _BAD_VALUE}
        try:
            candidate = type(component)(**params)
            _validate(candidate)
        except InvalidParameterError as error:
            assert name in str(error), f"The error for a bad {name!r} must name it: {error}"
        else:
            raise AssertionError(f"{type(component).__name__} accepted {name}={_BAD_VALUE!r}.")


def _validate(component: Configurable) -> None:
    if isinstance(component, Representation):
        component.setup(_check_spec(), seed=0)
    elif isinstance(component, Agent):
        component.setup(_check_domain_for(component).domain_spec, seed=0)
    else:
        component.validate_params()


def _set_up_copy(component: Configurable) -> Configurable:
    """A set-up clone on what the component needs (spec, check domain or check setting).

    Representations on the check spec, agents on their check domain, cooperative planners and
    risk analysers on the first check setting they accept.
    """
    if isinstance(component, (RiskAnalyzer, CooperativePlanner)):
        return _set_up_on_setting(component, seed=0)[0]
    clone = component.clone()
    _validate(clone)
    return clone


def _alternatives(constraint: Constraint, value: Any) -> list[Any]:
    """Valid values other than ``value`` for a parameter (none for components and functions)."""
    if isinstance(constraint, Options):
        return [option for option in constraint.options if option != value]
    if isinstance(constraint, AnyOf):
        return [v for option in constraint.options for v in _alternatives(option, value)]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return []
    candidates = [value + 1, 2 * value, value / 2, value - 1, 0.5, 0]
    if isinstance(value, int):
        candidates = [c for c in candidates if float(c).is_integer()]
        candidates = [int(c) for c in candidates]
    return [c for c in candidates if c != value and constraint.is_satisfied_by(c)]


def _same(a: Any, b: Any) -> bool:
    """Whether two compiled forms hold the same content.

    Named tuples field by field, arrays by value (NaN equal to NaN), numba structrefs by their
    fields, numpy Generators by their bit generator's state (a `CALLBACK` domain's key is
    replaced beforehand, `_form_content`): two set-ups of one configuration are the same,
    whichever objects they allocated.
    """
    if isinstance(a, tuple) and isinstance(b, tuple):
        return (
            type(a) is type(b)
            and len(a) == len(b)
            and all(_same(x, y) for x, y in zip(a, b, strict=True))
        )
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[key], b[key]) for key in a)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
    if isinstance(a, StructRefProxy) and isinstance(b, StructRefProxy):
        return typeof(a) == typeof(b) and _same(_structref_fields(a), _structref_fields(b))
    if isinstance(a, np.random.Generator) and isinstance(b, np.random.Generator):
        return _same(a.bit_generator.state, b.bit_generator.state)
    return bool(a == b) and type(a) is type(b)


def _structref_fields(value: StructRefProxy) -> tuple:
    """The fields of a numba structref, in its type's order (read by one compiled getter)."""
    return _field_reader(typeof(value))(value)


@functools.cache
def _field_reader(kind: Any) -> Callable[[Any], tuple]:
    """A compiled function returning every field of a structref of type ``kind``."""
    fields = ", ".join(f"value.{name}" for name in kind.field_dict)
    namespace: dict[str, Any] = {}
    exec(f"def read(value):\n    return ({fields},)", namespace)  # only the type's field names
    return njit(namespace["read"])


def _form_content(component: Configurable) -> Any:
    """The compiled form of a set-up copy of ``component``, None if it has none.

    A `CALLBACK` domain's form holds only a key to the live domain (the loop calls its own
    ``reset`` and ``step``), so its content is the domain's class and parameters, read while
    the copy is alive.
    """
    set_up = _set_up_copy(component)
    form = compiled_form(set_up)
    if isinstance(form, DomainKernel) and form.kind == CALLBACK:
        domain = callback_domain(form)
        key = np.zeros(0, dtype=np.int64)
        return form._replace(state=key), type(domain).__name__, repr(domain.get_params())
    return form


def check_compiled_form_covers_params(component: Configurable) -> None:
    """Every parameter reaches the compiled form, unless the class declares it irrelevant.

    For a component with a compiled form (`conjure.core.compiled_form`), changing any
    ``get_params()`` key to another valid value must change the set-up component's form,
    unless the key is in the class's ``compiled_irrelevant_params``. Keys whose constraint
    offers no other value here (a component, a function) are not varied: a component has its
    own form, checked on its own.
    """
    reference = _form_content(component)
    if reference is None:
        return
    irrelevant = getattr(component, "compiled_irrelevant_params", frozenset())
    params = component.get_params()
    ignored = []
    for name, constraint in component.parameter_constraints.items():
        if name in irrelevant:
            continue
        for other in _alternatives(constraint, params[name]):
            try:
                form = _form_content(type(component)(**{**params, name: other}))
            except (InvalidParameterError, IncompatibleComponentsError):
                continue  # another value may fit the other parameters
            if form is not None and _same(form, reference):
                ignored.append(f"{name}={other!r} (from {params[name]!r})")
            break
    assert not ignored, (
        f"{type(component).__name__}: {', '.join(ignored)} leave the compiled form unchanged; "
        f"the compiled loop would ignore them. Put them in the form or declare them in "
        f"`compiled_irrelevant_params`."
    )


def check_global_rng_untouched(component: Configurable) -> None:
    """Using the component never touches numpy's global random state."""
    before = np.random.get_state()  # noqa: NPY002 (checking that nobody uses it)
    _exercise(component)
    after = np.random.get_state()  # noqa: NPY002
    assert (
        before[0] == after[0] and np.array_equal(before[1], after[1]) and (before[2:] == after[2:])
    ), f"{type(component).__name__} used numpy's global random state."


def _exercise(component: Configurable) -> None:
    if isinstance(component, Domain):
        _domain_rollout(component, seed=3, num_steps=30)
    elif isinstance(component, Representation):
        spec = _check_spec()
        representation = component.clone().setup(spec, seed=0)
        for state in sample_states(spec, 20):
            _features(representation, state)
    elif isinstance(component, Policy):
        rng = make_rng(0)
        for _ in range(20):
            component.select(np.array([0.0, 1.0, 1.0]), rng, np.arange(3))
    elif isinstance(component, Agent):
        domain = _check_domain_for(component)
        agent = component.clone().setup(domain.domain_spec, seed=0)
        _rollout(domain, agent, 50, seed=0)
    elif isinstance(component, RiskAnalyzer):
        analyser, setting, _ = _set_up_on_setting(component, seed=0)
        analyser.risk(setting.unsafe_state, setting.unsafe_action)
    elif isinstance(component, CooperativePlanner):
        planner, setting, _ = _set_up_on_setting(component, seed=0)
        planner.action(setting.unsafe_state)


# ------------------------------------------------------------------------------ domains


def _domain_rollout(domain: Domain, seed: int, num_steps: int) -> list[tuple]:
    records = []
    observation, _ = domain.reset(seed=seed)
    action_rng = make_rng(seed)
    records.append(("reset", observation.tolist()))
    for _ in range(num_steps):
        legal = domain.legal_actions(observation)
        action = int(legal[action_rng.integers(legal.shape[0])])
        observation, reward, terminated, truncated, _ = domain.step(action)
        records.append((action, observation.tolist(), float(reward), terminated, truncated))
        if terminated or truncated:
            observation, _ = domain.reset()
            records.append(("reset", observation.tolist()))
    return records


def check_gymnasium_env(domain: Domain) -> None:
    """Gymnasium's ``check_env`` passes with its warnings turned into errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(domain.unwrapped, skip_render_check=True)


def check_seeded_rollout(domain: Domain) -> None:
    """The same seed gives the same rollout; the spec matches the spaces."""
    first = _domain_rollout(domain, seed=11, num_steps=60)
    second = _domain_rollout(domain.clone(), seed=11, num_steps=60)
    assert first == second, "The same seed gave different rollouts."
    spec = domain.domain_spec
    assert spec.num_actions == domain.action_space.n, "domain_spec.num_actions != action_space.n"
    assert spec.num_dims == domain.observation_space.shape[0], "domain_spec dims != observations"


def check_action_masks(domain: Domain) -> None:
    """``action_masks()`` is a bool array marking exactly the legal actions of the current state.

    Domains with action constraints also give it as ``info["action_mask"]`` at reset and step
    (`conjure.domains.action_masking`), along a rollout of random legal actions.
    """
    twin = domain.clone()
    num_actions = twin.domain_spec.num_actions
    has_constraints = twin.domain_spec.has_action_constraints
    name = type(twin).__name__
    observation, info = twin.reset(seed=7)
    action_rng = make_rng(7)
    for _ in range(40):
        legal = twin.legal_actions(observation)
        expected = np.zeros(num_actions, dtype=bool)
        expected[legal] = True
        mask = twin.action_masks()
        assert isinstance(mask, np.ndarray) and mask.dtype == bool, (
            f"{name}.action_masks() must return a bool ndarray; got {mask!r}."
        )
        assert np.array_equal(mask, expected), (
            f"{name}.action_masks() marks {np.flatnonzero(mask).tolist()} but legal_actions is "
            f"{legal.tolist()} in state {observation.tolist()}."
        )
        if has_constraints:
            given = info.get("action_mask")
            assert isinstance(given, np.ndarray) and np.array_equal(given, expected), (
                f"{name}: info['action_mask'] must equal the legal actions {legal.tolist()}; "
                f"got {given!r}."
            )
        action = int(legal[action_rng.integers(legal.shape[0])])
        observation, _, terminated, truncated, info = twin.step(action)
        if terminated or truncated:
            observation, info = twin.reset()


def check_pickle_round_trip(domain: Domain) -> None:
    """A pickled and restored domain continues the same rollout."""
    domain.reset(seed=5)
    twin = pickle.loads(pickle.dumps(domain))
    legal = domain.legal_actions(domain.reset(seed=5)[0])
    twin.reset(seed=5)
    action = int(legal[0])
    first, second = domain.step(action), twin.step(action)
    assert np.array_equal(first[0], second[0]) and first[1:4] == second[1:4], (
        "A pickled domain stepped differently from the original."
    )


def check_model_matches_simulation(domain: Domain) -> None:
    """If the domain has a ``model()``: it is valid and sampled transitions match P.

    Rows of P sum to one, R is finite and terminal states absorb (`TabularModel.check`); then,
    for a few non-terminal states and every action, 2,000 simulated steps from that state
    (through the domain's ``set_state``) land on each successor with the model's probability
    (absolute tolerance 0.05).
    """
    model = domain.model()
    if model is None:
        return
    model.check()
    if not hasattr(domain, "set_state"):
        return
    twin = domain.clone()
    twin.reset(seed=21)
    live = np.flatnonzero(~model.is_terminal)
    for state_index in live[:: max(1, live.size // 4)][:4]:
        for action in range(model.num_actions):
            counts = np.zeros(model.num_states)
            for _ in range(2000):
                twin.set_state(model.states[state_index])
                next_state = twin.step(action)[0]
                counts[model.state_index(next_state)] += 1
            expected = model.transitions[action][state_index].toarray().ravel()
            assert np.allclose(counts / 2000, expected, atol=0.05), (
                f"{type(domain).__name__}: from state {model.states[state_index].tolist()} "
                f"action {action}, simulated successor frequencies differ from the model's P."
            )


# ------------------------------------------------------------------------------ representations


def _features(representation: Representation, state: np.ndarray) -> np.ndarray:
    """φ(s) as a dense vector, from `Representation.encode`."""
    return representation.encode(state).dense(representation.num_features_)


def check_features_valid(representation: Representation) -> None:
    """`encode` gives sorted unique int64 indices in range with as many finite float64 values."""
    spec = _check_spec()
    rep = representation.clone().setup(spec, seed=0)
    assert rep.num_features_ > 0, "A set-up representation needs at least one feature."
    for state in sample_states(spec, 200):
        indices, values = rep.encode(state)
        assert indices.dtype == np.int64, f"encode's indices must be int64; got {indices.dtype}"
        assert values.dtype == np.float64, f"encode's values must be float64; got {values.dtype}"
        assert values.shape == indices.shape, "encode's indices and values differ in length."
        assert indices.size > 0, "Every state needs at least one active feature."
        assert np.all(np.diff(indices) > 0), f"Indices not sorted and unique: {indices}"
        assert indices[0] >= 0 and indices[-1] < rep.num_features_, f"Out of range: {indices}"
        assert np.all(np.isfinite(values)), f"Feature values not finite: {values}"
        again = rep.encode(state.copy())
        assert np.array_equal(indices, again.indices) and np.array_equal(values, again.values), (
            "φ(s) is not deterministic."
        )


def check_wrong_state_shape_raises(representation: Representation) -> None:
    """A state from another space raises `InvalidParameterError` naming the shape."""
    rep = representation.clone().setup(_check_spec(), seed=0)
    try:
        _features(rep, np.zeros(5))
    except InvalidParameterError as error:
        assert "(5,)" in str(error), f"The error must name the bad shape: {error}"
    else:
        raise AssertionError("A 5-D state was accepted by a representation set up for 2-D.")


def check_not_set_up_raises(component: Representation | Agent) -> None:
    """Using a component before ``setup`` raises `NotSetUpError`."""
    fresh = component.clone()
    if isinstance(fresh, Representation):
        calls = [lambda: fresh.encode(np.zeros(2))]
    else:
        state = np.zeros(1)
        calls = [
            lambda: fresh.act(state),
            lambda: fresh.learn(Transition(state, 0, 0.0, state, 0, False)),
        ]
    for call in calls:
        try:
            call()
        except NotSetUpError:
            continue
        raise AssertionError(f"{type(fresh).__name__} did not raise NotSetUpError before setup.")


def check_representation_state_round_trip(representation: Representation) -> None:
    """``state_arrays`` then ``load_state_arrays`` into a fresh copy preserves φ."""
    spec = _check_spec()
    rep = representation.clone().setup(spec, seed=1)
    states = sample_states(spec, 100, seed=2)
    expected = [_features(rep, state) for state in states]
    twin = representation.clone().setup(spec, seed=99)
    twin.load_state_arrays(copy.deepcopy(rep.state_arrays()))
    for state, phi in zip(states, expected, strict=True):
        assert np.array_equal(_features(twin, state), phi), "Restored φ differs."


# ------------------------------------------------------------------------------ policies


def check_policy_probabilities(policy: Policy) -> None:
    """Probabilities sum to one, are zero on illegal actions and match sampled frequencies."""
    values = np.array([0.5, 1.0, -2.0, 1.0])
    legal = np.array([0, 1, 3])
    probs = policy.probabilities(values, legal)
    assert np.isclose(probs.sum(), 1.0) and probs[2] == 0.0, f"Bad probabilities {probs}"
    rng = make_rng(0)
    counts = np.bincount([policy.select(values, rng, legal) for _ in range(4000)], minlength=4)
    assert np.allclose(counts / 4000, probs, atol=0.03), f"Sampled {counts / 4000} vs {probs}"


# ------------------------------------------------------------------------------ agents


def _trained(agent: Agent, num_steps: int, seed: int) -> tuple[Agent, Domain]:
    domain = _check_domain_for(agent)
    learner = agent.clone().setup(domain.domain_spec, seed=seed)
    _rollout(domain, learner, num_steps, seed=seed)
    return learner, domain


def check_actions_in_space(agent: Agent) -> None:
    """Every action lies in the action space, exploratory or greedy."""
    learner, domain = _trained(agent, 100, seed=0)
    n = domain.domain_spec.num_actions
    for state in _visited_states(domain, 50):
        for greedy in (False, True):
            action = learner.act(state, greedy=greedy)
            assert isinstance(action, int) and 0 <= action < n, f"Bad action {action!r}"


def _learned_weights(agent: Agent, prefix: str = "") -> dict[str, np.ndarray]:
    """Every ``*weights_`` array of the agent and of the agents it holds (e.g. ``learner_``).

    Attributes and properties alike (a TD learner's ``weights_`` is a view of its form).
    """
    weights = {}
    names = [*vars(agent), *(n for n in dir(type(agent)) if n.endswith("weights_"))]
    for name in dict.fromkeys(names):
        value = getattr(agent, name)
        if name.endswith("weights_"):
            weights[prefix + name] = value
        elif name.endswith("_") and isinstance(value, Agent):
            weights.update(_learned_weights(value, f"{prefix}{name}."))
    return weights


def check_agent_determinism(agent: Agent) -> None:
    """The same seed gives identical weights; the weights stay finite."""
    first, _ = _trained(agent, 300, seed=4)
    second, _ = _trained(agent, 300, seed=4)
    expected = _learned_weights(second)
    for name, value in _learned_weights(first).items():
        assert np.array_equal(value, expected[name]), f"{name} differs for one seed."
        assert np.all(np.isfinite(value)), f"{name} is not finite."


def check_save_restore_continues(agent: Agent) -> None:
    """N steps, save, restore, N more steps equals 2N straight steps."""
    domain = _check_domain_for(agent)
    straight = agent.clone().setup(domain.domain_spec, seed=8)
    _rollout(domain, straight, 200, seed=8)
    _rollout(domain, straight, 200, seed=9)

    halves = agent.clone().setup(domain.domain_spec, seed=8)
    _rollout(domain, halves, 200, seed=8)
    with tempfile.TemporaryDirectory() as directory:
        halves.save(directory)
        resumed = type(halves).restore(directory)
    _rollout(domain, resumed, 200, seed=9)
    expected = _learned_weights(resumed)
    for name, value in _learned_weights(straight).items():
        assert np.array_equal(value, expected[name]), f"{name} differs after restore."


def check_converges_on_chain(agent: Agent) -> None:
    """On a 2-state chain (γ = 0.9, reward 1 for moving right) Q(0, ·) nears Q* = (1, 0.9).

    Slow (a few thousand steps); the tests mark it. Tolerance 0.05 covers SARSA's ε-greedy
    fixed point, Q(0, stay) = 0.895.
    """
    from conjure.domains import ChainMDP

    domain = ChainMDP(num_states=2, num_actions=2)
    learner = agent.clone().setup(domain.domain_spec, seed=0)
    _rollout(domain, learner, 4000, seed=0)
    q = learner.q_values(np.zeros(1))
    assert np.allclose(q, [1.0, 0.9], atol=0.05), f"Q(0, ·) = {q}, expected about [1, 0.9]."


# ------------------------------------------------------------------------------ entry points

_CHECKS: dict[type, tuple[Check, ...]] = {
    Configurable: (
        check_constructor_only_stores,
        check_clone,
        check_params_round_trip,
        check_bad_params_raise,
        check_global_rng_untouched,
        check_compiled_form_covers_params,
    ),
    Domain: (
        check_gymnasium_env,
        check_seeded_rollout,
        check_action_masks,
        check_pickle_round_trip,
        check_model_matches_simulation,
    ),
    Representation: (
        check_features_valid,
        check_wrong_state_shape_raises,
        check_not_set_up_raises,
        check_representation_state_round_trip,
    ),
    Policy: (check_policy_probabilities,),
    Planner: (check_planner_matches_closed_form, check_planner_policy_is_greedy),
    CooperativePlanner: (check_cooperative_planner_legal, check_cooperative_planner_deterministic),
    RiskAnalyzer: (
        check_risk_planner_actions_safe,
        check_risk_flags_unsafe_action,
        check_risk_deterministic,
    ),
    Agent: (
        check_not_set_up_raises,
        check_actions_in_space,
        check_agent_determinism,
        check_save_restore_continues,
    ),
}
SLOW_CHECKS = (check_converges_on_chain,)


def applicable_checks(component: Configurable, slow: bool = False) -> Iterator[Check]:
    """Yield every check that applies to ``component``, minus its declared exceptions.

    With ``slow``, yield only the slow learning checks (for agents).
    """
    skipped = getattr(component, "expected_check_failures", {})
    if slow:
        candidates = SLOW_CHECKS if isinstance(component, Agent) else ()
    else:
        candidates = [c for kind, cs in _CHECKS.items() if isinstance(component, kind) for c in cs]
    for check in candidates:
        if check.__name__ not in skipped:
            yield check


def check_component(component: Configurable, slow: bool = False) -> None:
    """Run every applicable check on ``component``; raise on the first failure."""
    for check in applicable_checks(component, slow=slow):
        check(component)
