"""Same seed, same curve: iCCA's box (Algorithm 23) in the compiled loop and in Python."""

import numpy as np
import pytest

from conjure.agents import SARSA, ActorCritic, QLearning
from conjure.compiled import CompiledStepper, for_combination, why_not_compiled
from conjure.core.errors import InvalidParameterError
from conjure.core.schedules import EpisodicDecay
from conjure.domains import GridWorld, UAVMission
from conjure.experiments.loop import LearningLoop, greedy_episodes, run_episode
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import CBBAPlanner, ModelPlanner, ShortestPathPlanner, SwitchingPlanner
from conjure.representations import (
    ARiFDD,
    HashedTabular,
    IndependentDiscretization,
    OnlineIFDD,
    Tabular,
)
from conjure.safety import (
    AdaptiveCooperativeLearner,
    CooperativeActorCritic,
    CooperativeLearner,
    FuelRiskAnalyzer,
    MonteCarloRiskAnalyzer,
    NominalRiskAnalyzer,
)
from conjure.safety.monte_carlo_risk import grid_failures

CHUNKS = (0, 1, 337, 1500, 2162)


def _learner(variant: str) -> ActorCritic:
    if variant == "printed":  # Algorithm 23 as printed: Q critic, Algorithm 12's actor step
        return ActorCritic(representation=Tabular(), step_size=EpisodicDecay(alpha_0=0.1))
    return ActorCritic(  # Fig. 5-5's iCCA: V critic, log-policy actor (Fig. 5-6's: traces)
        representation=Tabular(),
        step_size=EpisodicDecay(alpha_0=1.0, n_0=100),
        actor_step_size=EpisodicDecay(alpha_0=1.0, n_0=1000),
        critic="v",
        actor_update="log_policy",
        trace_decay=1.0 if variant == "traces" else 0.0,
    )


def _box(domain: GridWorld, variant: str, risk=None) -> CooperativeActorCritic:
    model_domain = domain.clone().set_params(noise=0.0)
    fading = variant != "printed"
    return CooperativeActorCritic(
        learner=_learner(variant),
        planner=ModelPlanner(),
        risk=risk or NominalRiskAnalyzer(),
        model=ApproximateModel(domain=model_domain),
        bias=30.0 if fading else 100.0,
        bias_half_life=2.0 if fading else None,
    )


def _run(make_box, domain_factory, variant: str, seed: int, compiled: bool):
    """(stepper, agent) after `CHUNKS` of steps of ``make_box(domain, variant)``."""
    domain = domain_factory()
    agent = make_box(domain, variant).setup(domain.domain_spec, seed)
    if compiled:
        stepper = for_combination(domain, agent, seed=seed)
        assert isinstance(stepper, CompiledStepper)
    else:
        stepper = LearningLoop(domain, agent, seed=seed)
    for n in CHUNKS:
        stepper.advance(n)
    return stepper, agent


def _assert_same_steps(python, compiled) -> None:
    """Both paths took the same steps: counters and the learner's generator and updates."""
    learner, python_learner = compiled.agent.learner_, python.agent.learner_
    np.testing.assert_array_equal(learner.weights_, python_learner.weights_)
    assert learner.rng_.bit_generator.state == python_learner.rng_.bit_generator.state
    assert (compiled.total_steps, compiled.num_episodes, compiled.num_failures) == (
        python.total_steps,
        python.num_episodes,
        python.num_failures,
    )
    assert learner.num_learning_steps_ == python_learner.num_learning_steps_ == sum(CHUNKS)


def _noisy_uav_7_2() -> UAVMission:
    return UAVMission(scenario="uav-7-2", traverse_failure=0.05)


def _same_algorithm_24_steps(make_box, variant: str, seed: int):
    """Both paths of ``make_box(UAV 7-2, variant)``: the same counts, draws and steps.

    Returns (Python agent, compiled stepper, compiled agent) for further checks.
    """
    python, python_agent = _run(make_box, _noisy_uav_7_2, variant, seed, compiled=False)
    compiled, agent = _run(make_box, _noisy_uav_7_2, variant, seed, compiled=True)
    np.testing.assert_array_equal(agent.counts_, python_agent.counts_)
    assert agent.rng_.bit_generator.state == python_agent.rng_.bit_generator.state
    _assert_same_steps(python, compiled)
    return python_agent, compiled, agent


@pytest.mark.parametrize("variant", ["fading", "printed"])
@pytest.mark.parametrize(
    "world", [GridWorld.gridworld_1, lambda: GridWorld(map_name="gridworld2", noise=0.2)]
)
@pytest.mark.parametrize("seed", [0, 5])
def test_the_box_takes_the_same_steps_on_both_paths(variant, world, seed):
    python, python_agent = _run(_box, world, variant, seed, compiled=False)
    compiled, agent = _run(_box, world, variant, seed, compiled=True)
    learner, python_learner = agent.learner_, python_agent.learner_
    np.testing.assert_array_equal(agent.visits_, python_agent.visits_)
    np.testing.assert_array_equal(learner.actor_weights_, python_learner.actor_weights_)
    _assert_same_steps(python, compiled)
    assert learner.episode_ == python_learner.episode_ > 2
    assert agent.visits_.sum() > sum(CHUNKS)  # one visit per action choice
    # The Python box acts greedily on the compiled learner's weights like on its own.
    state = np.array([0.0, 0.0])
    assert agent.act(state, greedy=True) == python_agent.act(state, greedy=True)


def _uav_box(domain: UAVMission, variant: str) -> CooperativeActorCritic:
    """Fig. 5-6's iCCA on UAV 7-2: CBBA planned per state and the fuel rule, a hashed index."""
    learner = _learner(variant).set_params(representation=HashedTabular(capacity=20_000))
    return CooperativeActorCritic(
        learner=learner,
        planner=CBBAPlanner(variant="aggressive"),
        risk=FuelRiskAnalyzer(),
        model=ApproximateModel(domain=domain.clone().set_params(traverse_failure=0.0)),
        index=HashedTabular(capacity=20_000),
        bias=30.0 if variant != "printed" else 100.0,
        bias_half_life=2.0 if variant != "printed" else None,
    )


@pytest.mark.parametrize("variant", ["fading", "printed", "traces"])
def test_the_box_on_a_mission_takes_the_same_steps_on_both_paths(variant):
    python, python_agent = _run(_uav_box, _noisy_uav_7_2, variant, 1, compiled=False)
    compiled, agent = _run(_uav_box, _noisy_uav_7_2, variant, 1, compiled=True)
    learner, python_learner = agent.learner_, python_agent.learner_
    np.testing.assert_array_equal(agent.visits_, python_agent.visits_)
    np.testing.assert_array_equal(learner.actor_weights_, python_learner.actor_weights_)
    _assert_same_steps(python, compiled)
    assert compiled.num_failures > 0 and agent.planner_.num_cached_ > 200


def test_a_box_it_cannot_tabulate_stays_in_python_and_says_why():
    domain = GridWorld.gridworld_1()
    agent = _box(domain, "fading")
    agent.set_params(index=HashedTabular())  # rows by first visit: no table before learning
    agent.setup(domain.domain_spec, 0)
    assert for_combination(domain, agent) is None
    assert why_not_compiled(domain, agent).startswith(
        "CooperativeActorCritic with these parameters has no compiled kernel (a planner with"
    )


def test_a_box_around_growing_features_stays_in_python():
    domain = GridWorld.gridworld_1()
    agent = _box(domain, "fading")
    ifdd = OnlineIFDD(base=IndependentDiscretization(), discovery_threshold=0.1)
    agent.learner.set_params(representation=ifdd)
    agent.setup(domain.domain_spec, 0)
    assert for_combination(domain, agent) is None
    assert "on fixed features" in why_not_compiled(domain, agent)


def _csarsa(domain: GridWorld, variant: str) -> CooperativeLearner:
    model = ApproximateModel(domain=domain.clone().set_params(noise=0.0))
    step_size = EpisodicDecay(alpha_0=1.0, n_0=100)
    learner = (
        QLearning(representation=Tabular(), step_size=step_size)
        if variant == "qlearning"
        else SARSA(representation=Tabular(), step_size=step_size, trace_decay=0.5)
    )
    return CooperativeLearner(
        learner=learner,
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=model,
        num_known_visits=3 if variant != "printed" else 10,
        veto_reward=None if variant == "printed" else -1.0,
        trusted_knownness=0.9 if variant == "trusting" else None,
    )


@pytest.mark.parametrize("variant", ["veto", "printed", "trusting", "qlearning"])
@pytest.mark.parametrize(
    "world", [GridWorld.gridworld_1, lambda: GridWorld(map_name="gridworld2", noise=0.2)]
)
def test_algorithm_24_takes_the_same_steps_on_both_paths(variant, world):
    python, python_agent = _run(_csarsa, world, variant, 3, compiled=False)
    compiled, agent = _run(_csarsa, world, variant, 3, compiled=True)
    learner = agent.learner_
    np.testing.assert_array_equal(agent.counts_, python_agent.counts_)
    assert agent.rng_.bit_generator.state == python_agent.rng_.bit_generator.state
    _assert_same_steps(python, compiled)
    assert agent.counts_.sum() > 0 and learner.episode_ > 2


def _uav_csarsa(domain: UAVMission, variant: str) -> CooperativeLearner:
    """Figs. 5-9/5-13's CSARSA: CBBA planned per state, the fuel rule, a hashed index."""
    model = ApproximateModel(domain=domain.clone().set_params(traverse_failure=0.0))
    learner = SARSA(
        representation=HashedTabular(capacity=20_000),
        step_size=EpisodicDecay(alpha_0=0.1, n_0=1000),
        trace_decay=1.0 if variant != "qlearning" else 0.0,
    )
    if variant == "qlearning":
        learner = QLearning(representation=HashedTabular(capacity=20_000), step_size=0.1)
    return CooperativeLearner(
        learner=learner,
        planner=CBBAPlanner(variant="conservative" if variant == "conservative" else "aggressive"),
        risk=FuelRiskAnalyzer(),
        model=model,
        index=HashedTabular(capacity=20_000),
        num_known_visits=2,
        veto_reward=None if variant == "printed" else -1750.0,
    )


@pytest.mark.parametrize("variant", ["veto", "printed", "conservative", "qlearning"])
def test_algorithm_24_with_cbba_and_the_fuel_rule_takes_the_same_steps_on_both_paths(variant):
    python_agent, compiled, agent = _same_algorithm_24_steps(_uav_csarsa, variant, 4)
    assert compiled.num_failures > 0  # crashes happened: the rule judged real proposals
    # The box planned each state it met once, in the planner's own cache.
    assert agent.planner_.num_cached_ == python_agent.planner_.num_cached_ > 500


def test_a_full_box_index_raises_its_own_error_at_the_same_step_on_both_paths():
    errors, steps = [], []
    for make_stepper in (LearningLoop, for_combination):
        domain = UAVMission(scenario="uav-7-2", traverse_failure=0.05)
        agent = _uav_csarsa(domain, "veto").set_params(index=HashedTabular(capacity=30))
        agent.setup(domain.domain_spec, 3)
        stepper = make_stepper(domain, agent, seed=3)
        with pytest.raises(InvalidParameterError, match="HashedTabular is full") as raised:
            stepper.advance(5_000)
        errors.append(str(raised.value))
        steps.append((stepper.total_steps, agent.index_.num_stored_))
    assert errors[0] == errors[1] and steps[0] == steps[1] and steps[0][1] == 30


def _uav_csarsa_ifdd(domain: UAVMission, variant: str) -> CooperativeLearner:
    """Section 6.2.6's CSARSA + iFDD⁺ (a small ξ, so that features are discovered early).

    ``arifdd``: ARiFDD's splitting tiles under iFDD⁺ instead (Algorithm 22).
    """
    box = _uav_csarsa(domain, "printed" if variant == "printed" else "veto")
    ifdd = OnlineIFDD(
        base=IndependentDiscretization(), relevance="ifdd_plus", discovery_threshold=5.0
    )
    if variant == "arifdd":
        ifdd = ARiFDD(relevance="ifdd_plus", discovery_threshold=5.0, split_threshold=20.0)
    trace_decay = 0.9 if variant == "traces" else 0.0
    learner = SARSA(
        representation=ifdd, step_size=EpisodicDecay(alpha_0=0.1), trace_decay=trace_decay
    )
    return box.set_params(learner=learner, veto_reward=-20.0 if variant != "printed" else None)


@pytest.mark.parametrize("variant", ["veto", "printed", "traces", "arifdd"])
def test_algorithm_24_around_online_ifdd_takes_the_same_steps_on_both_paths(variant):
    python_agent, _, agent = _same_algorithm_24_steps(_uav_csarsa_ifdd, variant, 6)
    ifdd, python_ifdd = agent.learner_.representation_, python_agent.learner_.representation_
    assert ifdd.num_features_ == python_ifdd.num_features_ > ifdd.num_initial_features_
    if variant == "arifdd":
        assert ifdd.num_splits_ == python_ifdd.num_splits_ > 0
        np.testing.assert_array_equal(ifdd.retired_tiles_, python_ifdd.retired_tiles_)


def test_algorithm_24_around_unsparsified_ifdd_stays_in_python():
    domain = UAVMission(scenario="uav-7-2")
    agent = _uav_csarsa_ifdd(domain, "veto")
    agent.learner.representation.set_params(sparsify=False)
    agent.setup(domain.domain_spec, 0)
    assert for_combination(domain, agent) is None


def _uav_am_icca(domain: UAVMission, variant: str) -> AdaptiveCooperativeLearner:
    """Fig. 5-13's AM-iCCA: conservative -> aggressive CBBA below 25%, Algorithm 25's rollouts."""
    model = ApproximateModel(
        domain=domain.clone().set_params(traverse_failure=0.0),
        initial_noise=0.4 if variant != "calm-prior" else 0.3,
        prior_weight=100.0 if variant != "calm-prior" else 20.0,
        is_adaptive=variant != "static",
    )
    planner = SwitchingPlanner(
        conservative=CBBAPlanner(variant="conservative"),
        aggressive=CBBAPlanner(variant="aggressive"),
    )
    risk = FuelRiskAnalyzer() if variant == "fuel" else MonteCarloRiskAnalyzer(risk_tolerance=0.4)
    cls = CooperativeLearner if variant == "static" else AdaptiveCooperativeLearner
    return cls(
        learner=SARSA(
            representation=HashedTabular(capacity=20_000),
            step_size=EpisodicDecay(alpha_0=0.1, n_0=1000),
            trace_decay=1.0,
        ),
        planner=planner if variant != "static" else CBBAPlanner(variant="conservative"),
        risk=risk,
        model=model,
        index=HashedTabular(capacity=20_000),
        num_known_visits=2,
        veto_reward=-1750.0,
    )


@pytest.mark.parametrize("variant", ["adaptive", "calm-prior", "fuel", "static"])
def test_algorithm_26_on_a_mission_takes_the_same_steps_on_both_paths(variant):
    python_agent, _, agent = _same_algorithm_24_steps(_uav_am_icca, variant, 2)
    risk_rngs = [a.risk_.rng_.bit_generator.state for a in (agent, python_agent)]
    assert risk_rngs[0] == risk_rngs[1]
    model, python_model = agent.model_, python_agent.model_
    assert (model.noise_, model.num_moves_, model.num_unintended_) == (
        python_model.noise_, python_model.num_moves_, python_model.num_unintended_,
    )  # fmt: skip
    if variant != "static":
        assert agent.planned_noise_ == python_agent.planned_noise_
        assert agent.num_policy_changes_ == python_agent.num_policy_changes_
        assert agent.planner_.is_aggressive_ == python_agent.planner_.is_aggressive_
    if variant == "calm-prior":  # η̂ fell below 25%: the planner switched, counts restarted
        assert agent.num_policy_changes_ >= 1 and agent.planner_.is_aggressive_


def test_am_icca_stays_in_python():
    domain = GridWorld.gridworld_1()
    model = ApproximateModel(domain=domain.clone().set_params(noise=0.0), is_adaptive=True)
    agent = AdaptiveCooperativeLearner(
        learner=SARSA(representation=Tabular()),
        planner=ModelPlanner(),
        risk=NominalRiskAnalyzer(),
        model=model,
    ).setup(domain.domain_spec, 0)
    assert for_combination(domain, agent) is None


def _grid_am_icca(domain: GridWorld, variant: str) -> CooperativeLearner:
    """Figs. 5-12/5-14's boxes: shortest-path planners, Algorithm 25's rollouts in T̂ at 40%.

    ``adaptive``: AM-iCCA (conservative -> aggressive below 25%); ``trusting``: with the
    safety check off from knownness 0.3 (Section 5.5.3); ``static``: iCCA, conservative
    planner, static model; ``printed``: that with a vetoed proposal not learned.
    """
    model = ApproximateModel(
        domain=GridWorld(map_name="gridworld2", noise=0.2),
        initial_noise=0.4,
        is_adaptive=variant in ("adaptive", "trusting"),
    )
    learner = SARSA(
        representation=Tabular(), step_size=EpisodicDecay(alpha_0=0.1, n_0=100), trace_decay=1.0
    )
    risk = MonteCarloRiskAnalyzer(num_rollouts=5, risk_tolerance=0.2)
    if variant in ("static", "printed"):
        return CooperativeLearner(
            learner=learner, planner=ShortestPathPlanner.conservative(), risk=risk, model=model,
            veto_reward=None if variant == "printed" else -1.0,
        )  # fmt: skip
    planner = SwitchingPlanner(
        conservative=ShortestPathPlanner.conservative(), aggressive=ShortestPathPlanner.aggressive()
    )
    return AdaptiveCooperativeLearner(
        learner=learner, planner=planner, risk=risk, model=model,
        trusted_knownness=0.3 if variant == "trusting" else None,
    )  # fmt: skip


def _gridworld_2() -> GridWorld:
    return GridWorld(map_name="gridworld2", noise=0.2, step_reward=-0.01)


@pytest.mark.parametrize(
    ("variant", "world"),
    [
        ("adaptive", _gridworld_2),
        ("static", _gridworld_2),
        ("printed", _gridworld_2),
        ("trusting", GridWorld.gridworld_3),
    ],
)
def test_algorithm_26_on_a_grid_takes_the_same_steps_on_both_paths(variant, world):
    # Figs. 5-12 and 5-14: the rollouts draw from the analyser's generator on both paths; the
    # adaptive model counts the same moves and switches to the aggressive planner at once.
    python, python_agent = _run(_grid_am_icca, world, variant, 3, compiled=False)
    compiled, agent = _run(_grid_am_icca, world, variant, 3, compiled=True)
    np.testing.assert_array_equal(agent.counts_, python_agent.counts_)
    for name in ("rng_", "eval_rng_"):
        assert (
            getattr(agent, name).bit_generator.state
            == getattr(python_agent, name).bit_generator.state
        )
    assert agent.risk_.rng_.bit_generator.state == python_agent.risk_.rng_.bit_generator.state
    _assert_same_steps(python, compiled)
    model, python_model = agent.model_, python_agent.model_
    assert (model.noise_, model.num_moves_, model.num_unintended_) == (
        python_model.noise_, python_model.num_moves_, python_model.num_unintended_,
    )  # fmt: skip
    if variant in ("adaptive", "trusting"):  # GridWorld-3's 55% wind: no switch
        assert model.num_moves_ > 1000 and model.num_unintended_ > 0
        assert agent.num_policy_changes_ == python_agent.num_policy_changes_
        assert agent.planner_.is_aggressive_ == python_agent.planner_.is_aggressive_
        assert agent.planned_noise_ == python_agent.planned_noise_
    if variant == "adaptive":
        assert agent.num_policy_changes_ >= 1 and agent.planner_.is_aggressive_
    assert compiled.num_failures == python.num_failures


def test_the_grid_rollouts_renumbered_by_row_judge_as_the_analysers_own():
    # The box's rollouts run on T̂'s tables re-indexed by the index's rows; with the same
    # generator state they return the analyser's own risk(s, a) in every state and action.
    domain = _gridworld_2()
    agent = _grid_am_icca(domain, "static").setup(domain.domain_spec, 0)
    tables = agent.compiled_tables()
    grid = tables.grid._replace(rng=np.random.default_rng(5))
    planner_actions = tables.tables.conservative
    for state in agent.risk_.model_.domain_.model().states[::7]:
        row = agent.state_row(state)
        for action in range(4):
            expected = agent.risk_.risk(state, action, rng=np.random.default_rng(5))
            failures = grid_failures(grid, row, action, 0.4, planner_actions)
            grid = grid._replace(rng=np.random.default_rng(5))
            assert failures / 5 == expected


def test_the_analyser_judges_with_the_policy_a_compiled_switch_chose():
    # The compiled box switches π^p in the planner's own array and tells the analyser
    # nothing; its Python rollouts still follow the policy in use, as a twin's told by
    # `update` after the same counts.
    domain = _gridworld_2()
    agent = _grid_am_icca(domain, "adaptive").setup(domain.domain_spec, 0)
    states = agent.risk_.model_.domain_.model().states[::9]
    agent.risk_.risk(states[0], 0)  # π^p tabulated: the conservative policy
    for_combination(domain, agent, seed=0).advance(300)
    assert agent.planner_.is_aggressive_  # switched inside the kernel
    twin = _grid_am_icca(domain, "adaptive").setup(domain.domain_spec, 0)
    twin.model_.load_counts(agent.model_.num_unintended_, agent.model_.num_moves_)
    twin.risk_.update(is_policy_changed=twin.planner_.update(twin.model_))
    for state in states:
        for action in range(4):
            expected = twin.risk_.risk(state, action, rng=np.random.default_rng(7))
            assert agent.risk_.risk(state, action, rng=np.random.default_rng(7)) == expected


def test_the_box_tabulates_once_per_plan_and_again_after_a_restore(tmp_path):
    domain = GridWorld.gridworld_1()
    agent = _box(domain, "fading").setup(domain.domain_spec, 0)
    tables = agent.compiled_tables()
    assert agent.compiled_tables() is tables  # kept: π^p never changes while learning
    assert tables.safe.any() and not tables.safe.all()  # GridWorld-1's pits are vetoed
    for_combination(domain, agent, seed=0).advance(500)
    restored = CooperativeActorCritic.restore(agent.save(tmp_path / "box"))
    again = restored.compiled_tables()  # replanned by the restore, tabulated anew
    assert again is not tables
    np.testing.assert_array_equal(again.tables.conservative, tables.tables.conservative)
    np.testing.assert_array_equal(again.safe, tables.safe)


def test_a_box_keeps_one_compiled_form_its_state_until_a_restore(tmp_path):
    domain = GridWorld.gridworld_1()
    agent = _box(domain, "fading").setup(domain.domain_spec, 0)
    form = agent.compiled_form()
    for_combination(domain, agent, seed=0).advance(200)
    assert agent.compiled_form() is form  # its own arrays, updated in place by the kernel
    assert form.box.visits is agent.visits_ and form.box.visits.sum() > 0
    restored = CooperativeActorCritic.restore(agent.save(tmp_path / "box"))
    assert restored.compiled_form() is not form  # built anew around the restored state
    world = _gridworld_2()
    adaptive = _grid_am_icca(world, "adaptive").setup(world.domain_spec, 0)
    form = adaptive.compiled_form()
    for_combination(world, adaptive, seed=0).advance(300)
    assert adaptive.compiled_form() is form  # Algorithm 26 too: η̂^p and the switch shared
    assert adaptive.num_policy_changes_ >= 1  # written by the kernel, nothing taken back
    assert adaptive.planned_noise_ == adaptive.model_.noise_  # ΔT = 0: η̂^p follows η̂


@pytest.mark.parametrize(
    ("make_box", "world", "variant"),
    [
        (_box, GridWorld.gridworld_1, "fading"),
        (_box, lambda: GridWorld(map_name="gridworld2", noise=0.2), "printed"),
        (_csarsa, lambda: GridWorld(map_name="gridworld2", noise=0.2), "veto"),
        (_csarsa, GridWorld.gridworld_1, "trusting"),
        (_uav_box, _noisy_uav_7_2, "traces"),
        (_uav_csarsa, _noisy_uav_7_2, "veto"),
        (_uav_csarsa_ifdd, _noisy_uav_7_2, "veto"),
        (_uav_am_icca, _noisy_uav_7_2, "adaptive"),
        (_grid_am_icca, _gridworld_2, "adaptive"),
        (_grid_am_icca, GridWorld.gridworld_3, "trusting"),
    ],
)
def test_a_policy_check_plays_the_same_greedy_episodes_on_both_paths(make_box, world, variant):
    # The greedy box: unvisited states biased (23), only known pairs consulted (24), unsafe
    # moves replaced by π^p, Algorithm 25's rollouts drawn from the agent's evaluation
    # generator; nothing recorded.
    _, python_agent = _run(make_box, world, variant, 2, compiled=False)
    _, agent = _run(make_box, world, variant, 2, compiled=True)
    table = (agent.counts_ if hasattr(agent, "counts_") else agent.visits_).copy()
    before = [_box_state(python_agent), _box_state(agent)]
    python_domain, domain = world(), world()
    checks = []
    for _ in range(2):  # the second check replays the first one's start states
        seeds = [7] + [None] * 11
        checks.append([run_episode(python_domain, python_agent, seed=seed) for seed in seeds])
    stepper = for_combination(domain, agent, seed=7, learn=False)
    played = stepper.play_episodes(12)
    assert played.episode_returns.tolist() == [e.episode_return for e in checks[0]]
    assert played.episode_lengths.tolist() == [e.num_steps for e in checks[0]]
    assert played.episode_failures.tolist() == [e.num_failures for e in checks[0]]
    assert stepper.num_episodes == 12 and stepper.total_steps == sum(played.episode_lengths)
    assert greedy_episodes(domain, agent, 12, seed=7) == checks[1]  # the run's dispatcher
    assert agent.eval_rng_.bit_generator.state == python_agent.eval_rng_.bit_generator.state
    assert agent.learner_.num_learning_steps_ == sum(CHUNKS)  # nothing learned, nothing counted
    after = agent.counts_ if hasattr(agent, "counts_") else agent.visits_
    np.testing.assert_array_equal(after, table)
    # Neither path's checks stored a cell or changed a weight: the learner's features, θ (and
    # the actor's), the box's index and tables are as they were, and equal across paths.
    for old, new in zip(before, [_box_state(python_agent), _box_state(agent)], strict=True):
        assert new.keys() == old.keys()
        for key in old:
            np.testing.assert_array_equal(new[key], old[key], err_msg=key)
    assert python_agent.num_features == agent.num_features


def _box_state(agent) -> dict[str, np.ndarray]:
    """Every array a policy check must leave alone: the learner's and the box's."""
    learner = agent.learner_
    arrays = {"weights": learner.weights_, "num_features": np.array(agent.num_features)}
    if hasattr(learner, "actor_weights_"):
        arrays["actor_weights"] = learner.actor_weights_
    for prefix, part in (("representation.", learner.representation_), ("index.", agent.index_)):
        arrays.update({prefix + k: v for k, v in part.state_arrays().items()})
    for name in ("counts_", "visits_"):
        if hasattr(agent, name):
            arrays[name] = getattr(agent, name)
    return {key: np.array(value, copy=True) for key, value in arrays.items()}


@pytest.mark.parametrize("make_agent", [_uav_csarsa, _uav_am_icca])
def test_a_run_records_the_same_curve_on_both_paths_feature_counts_included(
    make_agent, monkeypatch
):
    # examples/uav_icca.yaml's CSARSA and AM-iCCA counted more features on the compiled path:
    # its policy checks stored the states they visited in the learner's HashedTabular.
    import pandas as pd

    import conjure.compiled
    from conjure.experiments import loop
    from conjure.experiments.run import run

    results = []
    for is_compiled in (False, True):
        with monkeypatch.context() as patch:
            if not is_compiled:  # learning and policy checks in Python
                patch.setattr(conjure.compiled, "is_warm", lambda stepper=None: False)
            domain = _noisy_uav_7_2()
            agent = make_agent(domain, "veto")
            steps = loop.COMPILE_WORTH_STEPS if is_compiled else None
            short = {"budget_steps": 600, "num_policy_checks": 2, "eval_episodes": 3}
            results.append(run(domain=domain, agent=agent, seed=5, compile_steps=steps, **short))
    python, compiled = results
    assert python.path.startswith("python") and compiled.path == "compiled"
    timing = ["wall_time_s", "steps_per_second"]
    curves = [pd.DataFrame(r.rows).drop(columns=timing) for r in results]
    pd.testing.assert_frame_equal(*curves)
    assert curves[0]["num_features"].iloc[0] == 0  # the check at step 0 stored nothing
    assert curves[0]["num_features"].iloc[-1] > 0
