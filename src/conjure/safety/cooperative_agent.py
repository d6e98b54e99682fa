"""The iCCA control box as an `Agent`: learner, planner, risk analyser and model (Figure 5-11)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from conjure.agents import persistence
from conjure.core.cooperative import CooperativePlanner, RiskAnalyzer
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Agent, DomainSpec, Representation, Transition, check_is_set_up
from conjure.core.params import InstanceOf
from conjure.core.seeding import make_rng, rng_from_state, rng_state, split_seed
from conjure.models.approximate_model import ApproximateModel
from conjure.representations import HashedTabular, Tabular
from conjure.safety._control_box import set_up_control_box
from conjure.safety.compiled_cooperative import BoxTables, CompiledBox, tabulate

__all__ = ["CooperativeAgent"]

#: The parts' seeds, split from the agent's seed in this order.
SEED_NAMES = ("model", "planner", "risk", "learner", "index", "behaviour", "evaluation")

LEARNER_DIRECTORY = "learner"

#: `CooperativeAgent.compiled_tables` not made yet (None means: cannot be tabulated).
_NOT_TABULATED = object()

#: The most rows the default `Tabular` index may have; larger state spaces get `HashedTabular`.
MAX_TABULAR_ROWS = 1_000_000


class ReplanState(NamedTuple):
    """Algorithm 26's η̂^p and count of policy changes, as the box's own arrays.

    Shared with the box's compiled form (`BoxParts`), so `box_learn` and the Python ``learn``
    update the same memory.

    Parameters
    ----------
    planned_noise : ndarray of float64, shape (1,)
        η̂^p, the noise estimate of the model π^p was last planned with.
    policy_changes : ndarray of int64, shape (1,)
        How often π^p changed (and the counts were reset).
    """

    planned_noise: np.ndarray
    policy_changes: np.ndarray


def default_index(spec: DomainSpec, seed: int | np.random.SeedSequence) -> Representation:
    """`Tabular` for state spaces up to `MAX_TABULAR_ROWS` cells, `HashedTabular` beyond."""
    try:
        tabular = Tabular().setup(spec, seed)
    except InvalidParameterError:  # more cells than an int64 index holds
        tabular = None
    if tabular is not None and tabular.num_features_ <= MAX_TABULAR_ROWS:
        return tabular
    return HashedTabular().setup(spec, seed)


class CooperativeAgent(Agent):
    """Base of the cooperative learners (Algorithms 23, 24, 26); not used directly.

    Geramifard (2012), Section 5.2 and Figures 5-3 and 5-11: iCCA's control box holds a
    learner, a cooperative planner and a risk analyser around an approximate model T̂. Here
    the box is an `Agent`, so the run loop drives it like any learner and never knows safety is
    in play; its parts are parameters, each a registered component.
    ``setup(spec, seed)`` splits the seed (`SEED_NAMES`) and builds, in order,
    model.setup → planner.setup(model) → risk.setup(model, planner) → learner.setup(spec), then
    the per-state tables indexed by ``index`` (one feature per state). ``act`` chooses the
    action (the algorithm's lines up to ``return a``); ``learn`` updates the learner with the
    executed action, which the run loop hands back in the `Transition`.

    Parameters
    ----------
    learner : Agent
        π^l: any online `Agent` of the library.
    planner : CooperativePlanner
        π^p.
    risk : RiskAnalyzer
        The ``safe`` test.
    model : ApproximateModel
        T̂: an `ApproximateModel` wrapping a `NoisyDomain` of the learning domain's map or
        graph (checked against the learning domain's spec in ``setup``).
    index : Representation or None, default None
        Gives each state its row in the per-state tables (see Notes).

    Notes
    -----
    - Choice: greedy acting (policy checks) records nothing: no count or visit, no new row of a
      lazily indexed ``index``, no draw from the behaviour generator; the risk analyser samples
      from a separate evaluation generator. Policy checks never perturb learning.
    - Choice: per-state tables (knownness counts, first visits) are indexed by ``index``, a
      representation with exactly one active feature per state. By default `Tabular`, or
      `HashedTabular` (capacity 100,000) when `Tabular` would need more than
      `MAX_TABULAR_ROWS` rows (UAV missions: 2.8 million cells for UAV 7-2).
    """

    parameter_constraints = {
        "learner": InstanceOf(Agent, "an online Agent (SARSA, QLearning, ActorCritic, ...)"),
        "planner": InstanceOf(CooperativePlanner, "a CooperativePlanner"),
        "risk": InstanceOf(RiskAnalyzer, "a RiskAnalyzer"),
        "model": InstanceOf(ApproximateModel, "an ApproximateModel"),
        "index": InstanceOf((Representation, type(None)), "a Representation or None"),
    }
    expected_check_failures = {
        "check_converges_on_chain": "a cooperative learner needs a NoisyDomain model of its "
        "learning domain, and the 2-state chain is not one; tests/safety check learning on grids",
    }

    def __init__(
        self,
        *,
        learner: Agent,
        planner: CooperativePlanner,
        risk: RiskAnalyzer,
        model: ApproximateModel,
        index: Representation | None = None,
    ):
        self.learner = learner
        self.planner = planner
        self.risk = risk
        self.model = model
        self.index = index

    # ------------------------------------------------------------------ lifecycle

    @property
    def compiled_learner(self) -> Agent:
        """The learner whose kernels the compiled loop runs inside a box with a compiled form.

        The box's own ``compiled_form`` (`conjure.safety.compiled_cooperative`) tabulates π^p
        and safe(s, a); the learner's compiled form runs the updates.
        """
        check_is_set_up(self, "compiled_learner")
        return self.learner_

    def setup(self, spec: DomainSpec, seed: int | np.random.SeedSequence) -> CooperativeAgent:
        """Set up model → planner → risk analyser → learner, then the per-state tables."""
        self.validate_params()
        if getattr(self.learner, "constraint", None) is not None:
            raise IncompatibleComponentsError(
                f"{type(self).__name__} cannot box a learner with a cost constraint "
                f"({self.learner.constraint!r}): the planner and risk analyser decide what is "
                f"safe; give the learner constraint=None."
            )
        seeds = split_seed(seed, SEED_NAMES)
        self.spec_ = spec
        self.model_, self.planner_, self.risk_ = set_up_control_box(
            spec, seeds, self.model, self.planner, self.risk
        )
        self.learner_ = self.learner.clone().setup(spec, seeds["learner"])
        if self.index is None:
            self.index_ = default_index(spec, seeds["index"])
        else:
            self.index_ = self.index.clone().setup(spec, seeds["index"])
        self.rng_ = make_rng(seeds["behaviour"])
        self.eval_rng_ = make_rng(seeds["evaluation"])
        self.replan_state_ = ReplanState(
            planned_noise=np.array([float(self.model_.noise_)]),
            policy_changes=np.zeros(1, dtype=np.int64),
        )
        self._all_actions = np.arange(spec.num_actions, dtype=np.int64)
        self._build_tables(self.index_.num_features_, spec.num_actions)
        self._compiled_tables: BoxTables | object | None = _NOT_TABULATED
        self._compiled_box: CompiledBox | object | None = _NOT_TABULATED
        self.is_set_up_ = True
        return self

    #: Whether the box learns T̂ and may switch π^p as it learns (Algorithm 26).
    adapts_model = False

    @property
    def planned_noise_(self) -> float:
        """η̂^p, the noise estimate of the model π^p was last planned with (``replan_state_``)."""
        return float(self.replan_state_.planned_noise[0])

    @planned_noise_.setter
    def planned_noise_(self, noise: float) -> None:
        self.replan_state_.planned_noise[0] = noise

    def compiled_tables(self) -> BoxTables | None:
        """π^p and safe(s, a) per index row for the compiled box (`tabulate`), or None.

        Made on the first call after `setup` or `load_state` (which replans) and kept: the
        boxes that have a compiled form never replan while learning.
        """
        check_is_set_up(self, "compiled_tables")
        if self._compiled_tables is _NOT_TABULATED:
            self._compiled_tables = tabulate(self)
        return self._compiled_tables

    def _kept_box(self, build: Callable[[Any], CompiledBox | None]) -> CompiledBox | None:
        """The box's compiled form, ``build(self)``: built once and kept as its state.

        The form holds the box's own arrays and generators and its parts' (``visits_`` or
        ``counts_``, ``replan_state_``, T̂'s counts, the planner's switch, the generators),
        updated in place by the kernels and the Python methods alike, so one form serves from
        its first use after `setup` (or `load_state`) on and nothing is taken back after a
        compiled call. Choice: it is built at the first ask, not in `setup`, since a run on the
        Python path never needs the tables.
        """
        if self._compiled_box is _NOT_TABULATED:
            self._compiled_box = build(self)
        return self._compiled_box

    def _build_tables(self, num_states: int, num_actions: int) -> None:
        """Allocate the per-state tables (subclasses)."""
        raise NotImplementedError

    def _table_arrays(self) -> dict[str, np.ndarray]:
        """The per-state tables by name (``name`` is attribute ``name_``), for `save`."""
        raise NotImplementedError

    def _extra_state(self) -> dict[str, Any]:
        """Further learned state as JSON-able values (attribute ``name_`` for key ``name``)."""
        return {}

    def begin_episode(self) -> None:
        """Forward the episode start to the learner."""
        check_is_set_up(self, "begin_episode")
        self.learner_.begin_episode()

    def before_policy_check(self) -> None:
        """Forward to the learner (a batch learner fits here; see `Agent`)."""
        check_is_set_up(self, "before_policy_check")
        self.learner_.before_policy_check()

    @property
    def num_features(self) -> int:
        """The learner's number of features."""
        check_is_set_up(self, "num_features")
        return self.learner_.num_features

    def state_row(self, state: np.ndarray, *, store: bool = True) -> int:
        """The row of ``state`` in the per-state tables: its one active ``index`` feature.

        With ``store=False`` (greedy acting) a lazily indexed representation (`HashedTabular`)
        only looks the state up, and −1 means it was never seen.
        """
        index_of = None if store else getattr(self.index_, "index_of", None)
        if index_of is not None:
            return int(index_of(state))
        active = self.index_.active_features(state)
        if active.shape[0] != 1:
            raise IncompatibleComponentsError(
                f"{type(self).__name__}.index must give one feature per state (Tabular, "
                f"HashedTabular); {type(self.index_).__name__} gave {active.shape[0]}."
            )
        return int(active[0])

    # ------------------------------------------------------------------ learning

    def learn(self, transition: Transition) -> float:
        """Update the learner with the executed action (``learner.update(s, r, a)``)."""
        check_is_set_up(self, "learn")
        return self.learner_.learn(transition)

    def _actions(self, legal_actions: np.ndarray | None) -> np.ndarray:
        return self._all_actions if legal_actions is None else legal_actions

    # ------------------------------------------------------------------ persistence

    def save(self, path: str | Path) -> Path:
        """Write the agent to directory ``path``; the learner goes to ``path/learner``."""
        check_is_set_up(self, "save")
        directory = Path(path)
        self.learner_.save(directory / LEARNER_DIRECTORY)
        arrays = persistence.prefixed("index.", self.index_.state_arrays())
        arrays.update(self._table_arrays())
        state = {
            "num_unintended": self.model_.num_unintended_,
            "num_moves": self.model_.num_moves_,
            "planned_noise": self.planned_noise_,
            "rng": rng_state(self.rng_),
            "evaluation_rng": rng_state(self.eval_rng_),
            "risk_rng": rng_state(self.risk_.rng_),
            "extra": self._extra_state(),
        }
        return persistence.write_agent(directory, self, state, arrays)

    @classmethod
    def restore(cls, path: str | Path) -> CooperativeAgent:
        """Load an agent written by `save`; it continues exactly as if never saved.

        π^p is re-made by replanning at the η̂ it was last planned at (planners are set up
        with seed 0, so a planner that draws random numbers re-plans differently), then T̂'s
        counts are restored. Every array is checked against the tables the agent set up from
        the saved spec allocates; a damaged save raises one error naming the file.
        """
        directory = Path(path)
        saved = persistence.read(directory)
        with saved.loading():
            agent = persistence.read_agent(cls, saved)
            agent.learner_ = type(agent.learner_).restore(directory / LEARNER_DIRECTORY)
            agent.load_state(saved)
        return agent

    def load_state(self, saved: persistence.SavedAgent) -> None:
        state = saved.state
        model = self.model_
        model.noise_ = self.planned_noise_ = float(state["planned_noise"])
        is_policy_changed = self.planner_.update(model)
        model.load_counts(int(state["num_unintended"]), int(state["num_moves"]))
        self.risk_.update(is_policy_changed=is_policy_changed)  # T̂ (and maybe π^p) changed
        self._compiled_tables = self._compiled_box = _NOT_TABULATED
        self.rng_ = rng_from_state(state["rng"])
        self.eval_rng_ = rng_from_state(state["evaluation_rng"])
        self.risk_.rng_ = rng_from_state(state["risk_rng"])
        self.index_.load_state_arrays(saved.with_prefix("index."))
        for name, table in self._table_arrays().items():
            table[...] = saved.array(name, table.shape, table.dtype)
        for name, value in state["extra"].items():
            if name not in self._extra_state():
                raise saved.damaged(persistence.METADATA_FILE, f"unknown state {name!r}")
            setattr(self, f"{name}_", value)
