"""The Monte-Carlo risk analyser of Geramifard (2012), Algorithm 25."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from conjure.core.compiled_form import compiled_form
from conjure.core.cooperative import RISK_TOLERANCE, RiskAnalyzer
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Domain, check_is_set_up
from conjure.core.params import InstanceOf, Interval
from conjure.domains.uav_mission import UAVMission, is_crashed, mission_step
from conjure.planners.cbba_planner import MissionPlanner, planned_action
from conjure.planners.switching_planner import PlannerPair
from conjure.safety import _kernels

__all__ = [
    "MAX_ROLLOUT_STEPS",
    "GridRollouts",
    "MissionRollouts",
    "MonteCarloRiskAnalyzer",
    "grid_failures",
    "mission_failures",
]

#: Most simulated transitions 𝓜𝓗 one judgement may take if no rollout ends early: seconds in
#: the compiled rollouts, minutes in Python ones, for each action the learner suggests
#: (Section 5.5.2's 𝓜 = 5 on GridWorld's 1000-step episodes: 5000).
MAX_ROLLOUT_STEPS = 100_000_000


class MonteCarloRiskAnalyzer(RiskAnalyzer):
    """risk(s, a) = the fraction of 𝓜 rollouts in T̂ (a, then π^p) that end constrained.

    Geramifard (2012), Algorithm 25 and Section 5.5.1: "use Monte-Carlo simulation to estimate
    the risk level associated with the given state-action pair if planner's policy is applied
    thereafter by simulating 𝓜 trajectories from the current state s. The first action is the
    suggested action a, and the rest of actions come from the planner's policy, π^p." Each
    rollout ends at a constrained state, a terminal state or after 𝓗 transitions; the action
    is safe iff risk < ε. The rollouts sample the model's *current* η̂, so an adaptive model
    sharpens the analyser as it learns (Figure 5-11).

    Parameters
    ----------
    num_rollouts : int, default 5
        𝓜 ≥ 1 (Section 5.5.2: 5).
    horizon : int or None, default None
        𝓗 ≥ 1 transitions per rollout; ``None`` takes the model domain's episode cap
        (``domain_spec.max_episode_steps``). 𝓜𝓗 may not exceed `MAX_ROLLOUT_STEPS`
        (``validate_params`` checks it with 𝓗 = 1 when ``None``; ``setup`` with the cap).
    risk_tolerance : float, default 0.2
        ε in (0, 1] (Section 5.5.2: 20%); safe iff risk < ε.

    Attributes
    ----------
    horizon_ : int
        𝓗 in use.
    rng_ : numpy.random.Generator
        The rollouts' generator, from ``setup``'s seed.
    is_compiled_ : bool
        Whether the rollouts run in the compiled tabular kernel (see Notes).

    Notes
    -----
    ======  =================  ==========================================
    Symbol  Name               Meaning
    ======  =================  ==========================================
    𝓜       num_rollouts       simulated trajectories per judgement
    𝓗       horizon            transitions per trajectory at most
    ε       risk_tolerance     the acceptable risk
    T̂       model              the approximate model, sampled at η̂
    ======  =================  ==========================================

    - Choice: 𝓗 is not given in the thesis; the default is the episode cap (spec section 5).
      UAV missions end at their horizon, so their rollouts stop there anyway.
    - Choice: risk is computed as the exact fraction k/𝓜, the value Algorithm 25's
      incremental mean reaches without its rounding (with 𝓜 = 5 and ε = 0.2 an action is
      safe iff no rollout fails).
    - Two readings of ε: Algorithm 25 prints ``risk < ε``; Figure 5-13's caption speaks of
      "the allowed risk level of 20%", i.e. ``risk ≤ ε``. ``risk_tolerance`` keeps the
      printed ``<``; the caption's reading at 𝓜 = 5 is ``risk_tolerance=0.4`` (one failed
      rollout in five). Figs. 5-9/5-13's page compares the two readings on UAV 7-2
      (docs/reproduction/fig_5_9_13.md).
    - Choice: when the model's domain has a `noise_decomposition` (grid worlds), rollouts run
      in a numba kernel over the two tabular models (`grid_failures`, which the compiled
      iCCA box calls too), drawing the noise with probability η̂ at each step; π^p is
      tabulated over the model's states and re-tabulated after `update` says π^p changed. On
      a UAV mission model with CBBA as π^p (a `CBBAPlanner` or a `SwitchingPlanner` of two),
      rollouts run in `mission_failures`: the mission's own random step and CBBA's cached
      plans, the kernel the compiled iCCA box calls too. Otherwise each
      step calls ``model.sample`` and ``planner.action`` in Python. All sample the same T̂.

    Complexity
    ----------
    Θ(𝓜𝓗) samples per judgement (tabular: Θ(𝓜𝓗k) for k successors per state-action).

    Examples
    --------
    >>> from conjure.domains import GridWorld
    >>> from conjure.models.approximate_model import ApproximateModel
    >>> from conjure.planners import ShortestPathPlanner
    >>> domain = GridWorld(map_name="4x5", noise=0.0)
    >>> model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    >>> planner = ShortestPathPlanner().setup(model, seed=0)
    >>> analyser = MonteCarloRiskAnalyzer().setup(model, planner, seed=0)
    >>> analyser.risk(np.array([2.0, 3.0]), 2)  # left, into the pit
    1.0
    >>> analyser.is_safe(np.array([2.0, 3.0]), 1)  # down, then to the goal
    True
    """

    parameter_constraints = {
        "num_rollouts": Interval(int, 1, None),
        "horizon": Interval(int, 1, None) | InstanceOf(type(None)),
        "risk_tolerance": RISK_TOLERANCE,
    }

    def __init__(
        self, *, num_rollouts: int = 5, horizon: int | None = None, risk_tolerance: float = 0.2
    ):
        self.num_rollouts = num_rollouts
        self.horizon = horizon
        self.risk_tolerance = risk_tolerance

    def validate_params(self) -> None:
        """Check each parameter, then 𝓜𝓗 (𝓗 = 1 if ``None``) against `MAX_ROLLOUT_STEPS`."""
        super().validate_params()
        _check_rollout_steps(self.num_rollouts, self.horizon)

    def _bind(self) -> None:
        """Fix 𝓗; build the compiled form (with 𝓜, 𝓗 and ε) once, as the analyser's state.

        On a UAV mission a `MissionRollouts`; where T̂ has a noise decomposition a
        `GridRollouts` of its tables. Choice: parameters set after ``setup`` take effect at the
        next ``setup`` (scikit-learn's contract), so the form is never re-stamped.
        """
        domain = self.model_.domain_
        if type(domain).is_constrained is Domain.is_constrained:
            raise IncompatibleComponentsError(
                f"MonteCarloRiskAnalyzer judges an action by how often rollouts reach a "
                f"constrained state (Algorithm 25), but {type(domain).__name__} never marks "
                f"one: it does not override Domain.is_constrained. Use a domain with failure "
                f"states (GridWorld, UAVMission, InvertedPendulum, ...) or define "
                f"is_constrained on yours."
            )
        if self.horizon is None:
            self.horizon_ = domain.domain_spec.max_episode_steps
            _check_rollout_steps(
                self.num_rollouts, self.horizon_, f" ({type(domain).__name__}'s max_episode_steps)"
            )
        else:
            self.horizon_ = self.horizon
        self._mission: MissionRollouts | None = None
        if isinstance(domain, UAVMission):
            graph = domain.graph_
            self._mission = MissionRollouts(
                num_rollouts=int(self.num_rollouts),
                horizon=self.horizon_,
                risk_tolerance=float(self.risk_tolerance),
                layout=graph.layout,
                node_table=graph.node_table,
                rng=self.rng_,
            )
        decomposition = domain.noise_decomposition()
        self.is_compiled_ = decomposition is not None
        self._grid: GridRollouts | None = None
        if self.is_compiled_:
            calm, windy = decomposition
            stacked = sp.vstack(
                [calm.state_major_transitions, windy.state_major_transitions], format="csr"
            )
            self._tabular = calm
            self._grid = GridRollouts(
                num_rollouts=int(self.num_rollouts),
                horizon=self.horizon_,
                risk_tolerance=float(self.risk_tolerance),
                num_actions=calm.num_actions,
                indptr=stacked.indptr.astype(np.int64),
                indices=stacked.indices.astype(np.int64),
                probabilities=stacked.data.astype(np.float64),
                is_constrained=np.array(
                    [domain.is_constrained(s) for s in calm.states], dtype=np.bool_
                ),
                is_terminal=np.asarray(calm.is_terminal, dtype=np.bool_),
                states=np.ascontiguousarray(calm.states, dtype=np.float64),
                rng=self.rng_,
            )

    compiled_methods = ("risk", "is_safe")

    def compiled_form(self) -> MissionRollouts | GridRollouts | None:
        """Algorithm 25 for the compiled iCCA box: on a UAV mission model or a tabular T̂.

        `MissionRollouts` (`mission_failures`, with CBBA as π^p) or `GridRollouts`
        (`grid_failures`, π^p a table the box supplies); None for other models.
        """
        check_is_set_up(self, "compiled_form")
        return self._mission if self._mission is not None else self._grid

    def simulated_steps(self) -> int:
        """𝓜𝓗: the rollouts of one judgement, each at most 𝓗 transitions of T̂."""
        return self.num_rollouts * self.horizon_

    def update(self, *, is_policy_changed: bool = True) -> None:
        """π^p changed: tabulate it again before the next compiled rollout.

        A change of T̂ alone needs nothing: the rollouts read η̂ from the model each time.
        """
        if is_policy_changed:
            self._policy: np.ndarray | None = None

    def _planner_switch(self) -> bool | None:
        """Which of a `SwitchingPlanner`'s policies is in use (None for other planners).

        The key of the tabulated π^p besides `update`: a compiled box switches the planner in
        place (its ``switch_``) and tells the analyser nothing.
        """
        return getattr(self.planner_, "is_aggressive_", None)

    def risk(self, state: np.ndarray, action: int, rng: np.random.Generator | None = None) -> float:
        """Algorithm 25: the fraction of 𝓜 rollouts from ⟨s, a⟩ that end constrained."""
        check_is_set_up(self, "risk")
        rng = self.rng_ if rng is None else rng
        planner = _mission_planner(self.planner_)
        if self._mission is not None and planner is not None:
            self.model_.nominal_next_state(state, action)  # checks s and that a is legal
            rollouts = self._mission._replace(rng=rng)
            state = np.asarray(state, dtype=np.float64)
            failures = mission_failures(rollouts, planner, state, int(action), self.model_.noise_)
        elif self.is_compiled_:
            failures = self._compiled_failures(state, int(action), rng)
        else:
            failures = sum(
                self._rollout_fails(state, int(action), rng) for _ in range(self.num_rollouts)
            )
        return failures / self.num_rollouts

    def _compiled_failures(self, state: np.ndarray, action: int, rng: np.random.Generator) -> int:
        tabular = self._tabular
        switch = self._planner_switch()
        if self._policy is None or switch != self._policy_switch:
            self._policy = np.array(
                [self.planner_.action(s) for s in tabular.states], dtype=np.int64
            )
            self._policy_switch = switch
        rollouts = self._grid._replace(rng=rng)
        return grid_failures(
            rollouts, tabular.state_index(state), action, float(self.model_.noise_), self._policy
        )

    def _rollout_fails(self, state: np.ndarray, action: int, rng: np.random.Generator) -> bool:
        """One rollout of Algorithm 25, lines 3-7, through ``model.sample``."""
        model, planner = self.model_, self.planner_
        state, _, terminated = model.sample(state, action, rng)  # line 4: s_t ~ T̂(s, a)
        t = 1
        constrained = model.is_constrained(state)
        while not constrained and not terminated and t < self.horizon_:  # line 5
            state, _, terminated = model.sample(state, planner.action(state), rng)  # line 6
            t += 1
            constrained = model.is_constrained(state)
        return constrained


class GridRollouts(NamedTuple):
    """Algorithm 25 in a tabular T̂ = (1 − η̂)·P_0 + η̂·P_1 as a compiled kernel reads it.

    Geramifard (2012), Algorithm 25 on a model whose domain has a `noise_decomposition`
    (grid worlds): `grid_failures`. The stacked CSR rows ((k·|S| + s)·|A| + a) are P_k^a(s, ·).

    Parameters
    ----------
    num_rollouts, horizon, risk_tolerance, rng
        As in `MissionRollouts`.
    num_actions : int
        |A|.
    indptr, indices, probabilities : ndarray
        P_0 stacked over P_1, state-major CSR.
    is_constrained, is_terminal : ndarray of bool, shape (|S|,)
        Which states are constrained (pits) and which end an episode.
    states : ndarray, shape (|S|, dims)
        The state of each index (the compiled box re-indexes the tables by its own rows).
    """

    num_rollouts: int
    horizon: int
    risk_tolerance: float
    num_actions: int
    indptr: np.ndarray
    indices: np.ndarray
    probabilities: np.ndarray
    is_constrained: np.ndarray
    is_terminal: np.ndarray
    states: np.ndarray
    rng: np.random.Generator


@njit(cache=True)
def grid_failures(
    rollouts: GridRollouts, state: int, action: int, noise: float, policy: np.ndarray
) -> int:
    """How many of 𝓜 rollouts from ⟨s, a⟩, then π^p (``policy[s]``), end constrained.

    Algorithm 25, lines 2-8, on T̂ at η̂ = ``noise`` (`_kernels.count_failures`); ``state``
    indexes the tables, ``policy`` gives π^p per index.
    """
    return _kernels.count_failures(
        state, action, noise, rollouts.num_rollouts, rollouts.horizon, rollouts.num_actions,
        rollouts.indptr, rollouts.indices, rollouts.probabilities, policy,
        rollouts.is_constrained, rollouts.is_terminal, rollouts.rng,
    )  # fmt: skip


class MissionRollouts(NamedTuple):
    """Algorithm 25 on a UAV mission model as a compiled kernel reads it (`mission_failures`).

    Parameters
    ----------
    num_rollouts, horizon : int
        𝓜 and 𝓗.
    risk_tolerance : float
        ε: safe iff risk < ε.
    layout, node_table : ndarray
        The model mission's kernel tables (`MissionGraph.layout`, `MissionGraph.node_table`).
    rng : numpy.random.Generator
        The analyser's ``rng_``.
    """

    num_rollouts: int
    horizon: int
    risk_tolerance: float
    layout: np.ndarray
    node_table: np.ndarray
    rng: np.random.Generator


@njit(cache=True)
def mission_failures(
    rollouts: MissionRollouts, planner: MissionPlanner, state: np.ndarray, action: int, noise: float
) -> int:
    """How many of 𝓜 rollouts from ⟨s, a⟩, then π^p (CBBA's cached plans), end crashed.

    Algorithm 25, lines 2-8, on T̂ at η̂ = ``noise``: each step is the mission's own random
    step (`mission_step`, 2n uniforms from ``rollouts.rng``) and a crash its constrained state;
    a rollout ends crashed, terminal or after 𝓗 transitions. ``state`` is a valid float64
    mission state and ``action`` legal there.
    """
    layout = rollouts.layout
    start = state.astype(np.int64)
    observed = np.empty(state.shape[0])
    failures = 0
    for _ in range(rollouts.num_rollouts):
        current, _, terminated, _ = mission_step(  # line 4: s_t ~ T̂(s, a)
            start, action, layout, rollouts.node_table, noise, rollouts.rng
        )
        t = 1
        constrained = is_crashed(current, layout)
        while not constrained and not terminated and t < rollouts.horizon:  # line 5
            for k in range(current.shape[0]):
                observed[k] = current[k]
            move = planned_action(planner, observed)
            current, _, terminated, _ = mission_step(  # line 6
                current, move, layout, rollouts.node_table, noise, rollouts.rng
            )
            t += 1
            constrained = is_crashed(current, layout)
        failures += constrained
    return failures


def _mission_planner(planner: object) -> MissionPlanner | None:
    """The CBBA form π^p is in use in (`planned_action`), or None for other planners."""
    form = compiled_form(planner)
    if isinstance(form, PlannerPair):
        return form.aggressive if form.is_aggressive[0] else form.conservative
    return form if isinstance(form, MissionPlanner) else None


def _check_rollout_steps(num_rollouts: int, horizon: int | None, source: str = "") -> None:
    """Refuse judgements of more than `MAX_ROLLOUT_STEPS` simulated transitions 𝓜𝓗.

    ``horizon`` ``None`` (not known before setup) counts as 1; ``source`` says where 𝓗 came from.
    """
    total = num_rollouts * (1 if horizon is None else horizon)
    if total <= MAX_ROLLOUT_STEPS:
        return
    if horizon is None:
        count = f"`MonteCarloRiskAnalyzer.num_rollouts` {num_rollouts:,}: at least {total:.3g}"
    else:
        count = (
            f"`MonteCarloRiskAnalyzer.num_rollouts` × horizon = {num_rollouts:,} × {horizon:,}"
            f"{source} = {total:.3g}"
        )
    raise InvalidParameterError(
        f"{count} simulated transitions per judged action, more than MAX_ROLLOUT_STEPS = "
        f"{MAX_ROLLOUT_STEPS:,}. Lower num_rollouts or horizon, or raise "
        f"conjure.safety.monte_carlo_risk.MAX_ROLLOUT_STEPS to simulate more."
    )
