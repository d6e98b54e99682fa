import numpy as np
import pytest

from conjure.core.cooperative import CooperativePlanner
from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.core.interfaces import Domain
from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import ShortestPathPlanner
from conjure.safety import MonteCarloRiskAnalyzer

LEFT, RIGHT = 2, 3
CORRIDOR = np.array([[4, 0, 2, 3]])  # pit, free, start, goal
START = np.array([0.0, 2.0])


class Undecomposed(GridWorld):
    """A grid world that hides its noise decomposition: rollouts run through model.sample."""

    def noise_decomposition(self):
        return None


def analyser_on(domain, planner=None, seed=0, **params):
    model = ApproximateModel(domain=domain).setup(domain.domain_spec, seed=0)
    planner = (planner or ShortestPathPlanner()).setup(model, seed=0)
    return MonteCarloRiskAnalyzer(**params).setup(model, planner, seed=seed)


def exact_risk(eta):
    """Moving left from the start, then right (π^p) until the goal or the pit, by hand.

    In the corridor the wind picks left or right with probability η/2 each. From cell 1 the
    pit is reached with p1 = η/2 + (1 − η/2) p2, from cell 2 with p2 = (η/2) p1; the first
    move (left) reaches cell 1 with probability 1 − η/2 (else the goal).
    """
    q = eta / 2
    p1 = q / (1 - (1 - q) * q)
    return (1 - q) * p1


@pytest.mark.parametrize("make", [GridWorld.from_grid, Undecomposed.from_grid])
def test_risk_matches_the_hand_computed_probability(make):
    analyser = analyser_on(make(CORRIDOR, noise=0.4), num_rollouts=20_000)
    assert analyser.is_compiled_ == (make == GridWorld.from_grid)
    assert exact_risk(0.4) == pytest.approx(0.190476, abs=1e-6)
    assert analyser.risk(START, LEFT) == pytest.approx(exact_risk(0.4), abs=0.012)


def test_the_horizon_bounds_each_rollout():
    domain = GridWorld.from_grid(CORRIDOR, noise=0.4)
    # One transition can never reach the pit two cells away.
    assert analyser_on(domain, horizon=1, num_rollouts=2000).risk(START, LEFT) == 0.0
    # Two: reach cell 1 (1 − η/2 = 0.8), then the wind blows left (η/2 = 0.2): 0.16.
    two = analyser_on(domain, horizon=2, num_rollouts=20_000).risk(START, LEFT)
    assert two == pytest.approx(0.8 * 0.2, abs=0.011)
    assert analyser_on(domain).horizon_ == domain.domain_spec.max_episode_steps


def test_the_current_noise_estimate_is_sampled():
    domain = GridWorld.from_grid(CORRIDOR, noise=0.4)
    model = ApproximateModel(domain=domain, initial_noise=0.4, prior_weight=0.0, is_adaptive=True)
    model = model.setup(domain.domain_spec, seed=0)
    analyser = MonteCarloRiskAnalyzer(num_rollouts=200)
    analyser.setup(model, ShortestPathPlanner().setup(model, seed=0), seed=0)
    assert analyser.risk(START, LEFT) > 0.0
    model.load_counts(num_unintended=0, num_moves=10)  # η̂ = 0: the nominal path is safe
    assert analyser.risk(START, LEFT) == 0.0


def test_estimates_are_deterministic_for_a_seed_and_an_explicit_generator_is_used():
    domain = GridWorld.gridworld_2()
    first, second = (analyser_on(domain, seed=7) for _ in range(2))
    states = [np.array([2.0, c]) for c in range(11, 22)]
    risks = [first.risk(s, a) for s in states for a in range(4)]
    assert risks == [second.risk(s, a) for s in states for a in range(4)]
    before = first.rng_.bit_generator.state
    first.risk(states[0], 0, np.random.default_rng(1))
    assert first.rng_.bit_generator.state == before


def test_safe_iff_the_risk_is_below_the_tolerance():
    # With 𝓜 = 5 and ε = 0.2 an action is safe iff none of its five rollouts fails.
    domain = GridWorld.from_grid(CORRIDOR, noise=0.4)
    by_risk, by_safe = analyser_on(domain, seed=3), analyser_on(domain, seed=3)
    risks = [by_risk.risk(START, LEFT) for _ in range(50)]
    assert [by_safe.is_safe(START, LEFT) for _ in range(50)] == [r < 0.2 for r in risks]
    assert 0.0 in risks and any(r > 0 for r in risks)


class FlippablePlanner(CooperativePlanner):
    """Heads right (to the goal) or left (to the pit)."""

    def __init__(self):
        pass

    def setup(self, model, seed):
        self.direction_ = RIGHT
        self.is_set_up_ = True
        return self

    def action(self, state):
        return self.direction_


def test_a_changed_planner_is_tabulated_again_after_update():
    domain = GridWorld.from_grid(np.array([[4, 0, 2, 0, 3]]), noise=0.0)
    analyser = analyser_on(domain, planner=FlippablePlanner())
    state = np.array([0.0, 2.0])
    assert analyser.risk(state, RIGHT) == 0.0
    analyser.planner_.direction_ = LEFT
    assert analyser.risk(state, RIGHT) == 0.0  # still the tabulated π^p
    analyser.update(is_policy_changed=False)  # only T̂ changed: the rollouts read η̂ anew
    assert analyser.risk(state, RIGHT) == 0.0
    analyser.update()
    assert analyser.risk(state, RIGHT) == 1.0  # right, then left three times into the pit


def test_bad_parameters_are_refused():
    with pytest.raises(InvalidParameterError, match="risk_tolerance"):
        MonteCarloRiskAnalyzer(risk_tolerance=0.0).validate_params()
    with pytest.raises(InvalidParameterError, match="num_rollouts"):
        MonteCarloRiskAnalyzer(num_rollouts=0).validate_params()


@pytest.mark.parametrize(
    ("params", "product"),
    [
        ({"num_rollouts": 10**9}, "num_rollouts` 1,000,000,000: at least 1e+09 simulated"),
        ({"horizon": 10**9}, "horizon = 5 × 1,000,000,000 = 5e+09 simulated"),
    ],
)
def test_absurd_rollout_counts_and_horizons_are_refused_with_the_bound(params, product):
    # Issue 20: 10⁹ rollouts were accepted and every learning step ground on silently.
    with pytest.raises(InvalidParameterError) as error:
        MonteCarloRiskAnalyzer(**params).validate_params()
    message = str(error.value)
    assert product in message and "MAX_ROLLOUT_STEPS = 100,000,000" in message
    assert "raise conjure.safety.monte_carlo_risk.MAX_ROLLOUT_STEPS" in message


def test_a_horizon_taken_from_an_absurd_episode_cap_is_refused_at_setup():
    # The largest episode cap a domain accepts (10^6) times 200 rollouts.
    domain = GridWorld.from_grid(CORRIDOR, noise=0.4, max_episode_steps=10**6)
    analyser = MonteCarloRiskAnalyzer(num_rollouts=200)
    analyser.validate_params()  # 𝓗 is not known before setup
    with pytest.raises(
        InvalidParameterError, match=r"200 × 1,000,000 \(GridWorld's max_episode_steps\) = 2e"
    ):
        analyser_on(domain, num_rollouts=200)
    assert analyser_on(domain, num_rollouts=200, horizon=1000).horizon_ == 1000  # 𝓗 given


def test_uav_rollouts_follow_cbba_and_match_the_exact_crash_probability():
    # UAV 7-2 [R]: UAV 0 at node 1 (one hop from the base) with 2 fuel, UAV 1 at the base with
    # none, t = 1. Flying home fails with η̂ = 0.4 per try; CBBA (no target fits 1 fuel) then
    # sends it home again, and a second failure strands it: risk = η̂² = 0.16.
    from conjure.domains import UAVMission
    from conjure.planners import CBBAPlanner

    domain = UAVMission()
    model = ApproximateModel(domain=domain, initial_noise=0.4).setup(domain.domain_spec, seed=0)
    planner = CBBAPlanner(variant="aggressive").setup(model, seed=0)
    analyser = MonteCarloRiskAnalyzer(num_rollouts=4000).setup(model, planner, seed=0)
    graph = domain.graph_
    state = graph.initial_state()
    state[0], state[1], state[3], state[-1] = 1.0, 2.0, 0.0, 1.0
    home = graph.encode_action([0, 0])
    assert not analyser.is_compiled_  # missions have no tabular noise decomposition
    assert analyser.risk(state, home) == pytest.approx(0.16, abs=0.02)
    # Onward to node 3 (two hops out, 1 fuel left) is safe only if that traversal fails and
    # the next flight home succeeds: risk = 1 − 0.4 · 0.6 = 0.76.
    onward = graph.encode_action([3, 0])
    assert analyser.risk(state, onward) == pytest.approx(0.76, abs=0.02)
    assert planner.num_cached_ > 0  # π^p at every rollout step, cached by state


class NeverFails(GridWorld):
    """A grid world that marks no state constrained (the `Domain` default)."""

    is_constrained = Domain.is_constrained


def test_a_domain_without_failure_states_is_refused_by_name():
    domain = NeverFails(map_name=CORRIDOR, noise=0.1)
    with pytest.raises(IncompatibleComponentsError, match=r"NeverFails.*is_constrained"):
        analyser_on(domain)
