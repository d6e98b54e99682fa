"""The shipped checks catch the defects they exist for."""

import numpy as np
import pytest

from conjure.core import Representation
from conjure.core.params import Interval
from conjure.core.schedules import ConstantStepSize, EpisodicDecay, FeatureNormalizedDecay
from conjure.policies import EpsilonGreedy
from conjure.representations import OnlineIFDD, Tabular
from conjure.safety import MonteCarloRiskAnalyzer
from conjure.testing import applicable_checks, check_component, checks
from conjure.testing.checks import check_compiled_form_covers_params


class Unsorted(Representation):
    """Section 0: a deliberately broken representation."""

    def __init__(self, *, num_buckets: int = 4):
        self.num_buckets = num_buckets

    def setup(self, spec, seed):
        self.spec_, self.num_features_, self.is_set_up_ = spec, 8, True
        return self

    def active_features(self, state):
        return np.array([5, 1], dtype=np.int64)


class Meddling(Tabular):
    """A constructor that changes its parameter, and a setup that uses global random state."""

    parameter_constraints = {"num_buckets": Interval(int, 1, None)}

    def __init__(self, *, num_buckets: int = 4):
        self.num_buckets = int(num_buckets) * 1

    def setup(self, spec, seed):
        np.random.random()  # noqa: NPY002 - the defect under test
        return super().setup(spec, seed)


def test_unsorted_features_are_caught():
    with pytest.raises(AssertionError, match="not sorted"):
        checks.check_features_valid(Unsorted())


def test_global_random_state_is_caught():
    with pytest.raises(AssertionError, match="global random state"):
        checks.check_global_rng_untouched(Meddling())


def test_missing_setup_guard_is_caught():
    with pytest.raises(AssertionError, match="NotSetUpError"):
        checks.check_not_set_up_raises(Unsorted())


def test_expected_failures_skip_only_the_named_check():
    class Excused(Unsorted):
        expected_check_failures = {"check_features_valid": "deliberately unsorted"}

    names = {check.__name__ for check in applicable_checks(Excused())}
    assert "check_features_valid" not in names and "check_clone" in names


def test_a_correct_component_passes_everything():
    check_component(Tabular(num_buckets=3))


def test_a_model_that_disagrees_with_the_simulator_is_caught():
    from conjure.domains import GridWorld

    class WrongModel(GridWorld):
        """Section 5.1: simulates noise 0.3 but claims a noise-free model."""

        def model(self):
            return GridWorld(map_name=self.map_name, noise=0.0).model()

    checks.check_model_matches_simulation(GridWorld(map_name="4x5", noise=0.3))
    with pytest.raises(AssertionError, match="differ from the model"):
        checks.check_model_matches_simulation(WrongModel(map_name="4x5", noise=0.3))


def test_broken_risk_analysers_are_caught():
    from conjure.safety import NominalRiskAnalyzer

    class Paranoid(NominalRiskAnalyzer):
        """Judges even the planner's actions unsafe (Section 5.5.1's collapse to the planner)."""

        def is_safe(self, state, action, rng=None):
            return False

    class Careless(NominalRiskAnalyzer):
        def risk(self, state, action, rng=None):
            return 0.0

    class Erratic(NominalRiskAnalyzer):
        def risk(self, state, action, rng=None):
            return float(np.random.default_rng().random())

    with pytest.raises(AssertionError, match="judged unsafe"):
        checks.check_risk_planner_actions_safe(Paranoid())
    with pytest.raises(AssertionError, match="expected in"):
        checks.check_risk_flags_unsafe_action(Careless())
    with pytest.raises(AssertionError, match="differ for one seed"):
        checks.check_risk_deterministic(Erratic())


def test_a_planner_suggesting_illegal_actions_is_caught():
    from conjure.planners import CBBAPlanner

    class Reckless(CBBAPlanner):
        def action(self, state):
            return self.graph_.encode_action([3, 3])  # three hops from the base at once

    with pytest.raises(AssertionError, match="is not legal"):
        checks.check_cooperative_planner_legal(Reckless())


def test_a_mask_that_disagrees_with_legal_actions_is_caught():
    from conjure.domains import BlocksWorld

    class Unmasked(BlocksWorld):
        def action_masks(self):
            return np.ones(self.domain_spec.num_actions, dtype=bool)

    with pytest.raises(AssertionError, match=r"action_masks\(\) marks"):
        checks.check_action_masks(Unmasked())

    class NoInfoMask(BlocksWorld):
        def reset(self, *, seed=None, options=None):
            return super().reset(seed=seed, options=options)[0], {}

    with pytest.raises(AssertionError, match="info\\['action_mask'\\]"):
        checks.check_action_masks(NoInfoMask())


class _Forgetful(EpsilonGreedy):
    """ε-greedy with a parameter its compiled form (ε's) does not carry."""

    parameter_constraints = {**EpsilonGreedy.parameter_constraints, "greed": Interval(float, 0, 1)}

    def __init__(self, *, epsilon: float = 0.1, greed: float = 0.5):
        super().__init__(epsilon=epsilon)
        self.greed = greed


def test_compiled_form_check_names_a_parameter_the_form_drops():
    with pytest.raises(AssertionError, match=r"greed=1\.0"):
        check_compiled_form_covers_params(_Forgetful())


@pytest.mark.parametrize(
    "schedule",
    [ConstantStepSize(alpha_0=0.3), FeatureNormalizedDecay(), EpisodicDecay(alpha_0=0.2, n_0=5)],
)
def test_schedules_carry_every_parameter_into_their_compiled_form(schedule):
    check_compiled_form_covers_params(schedule)


class _ForgetfulIFDD(OnlineIFDD):
    """iFDD with a parameter its compiled form (a structref of tables) does not carry."""

    parameter_constraints = {
        "base": OnlineIFDD.parameter_constraints["base"],
        "discovery_threshold": OnlineIFDD.parameter_constraints["discovery_threshold"],
        "greed": Interval(float, 0, 1),
    }

    def __init__(self, *, base=None, discovery_threshold: float = 1.0, greed: float = 0.5):
        base = Tabular(num_buckets=3) if base is None else base
        super().__init__(base=base, discovery_threshold=discovery_threshold)
        self.greed = greed


class _ForgetfulRisk(MonteCarloRiskAnalyzer):
    """Algorithm 25 with a parameter its compiled form (which holds a Generator) drops."""

    parameter_constraints = {
        "num_rollouts": MonteCarloRiskAnalyzer.parameter_constraints["num_rollouts"],
        "greed": Interval(float, 0, 1),
    }

    def __init__(self, *, num_rollouts: int = 5, greed: float = 0.5):
        super().__init__(num_rollouts=num_rollouts)
        self.greed = greed


@pytest.mark.parametrize("component", [_ForgetfulIFDD(), _ForgetfulRisk()], ids=repr)
def test_compiled_form_check_sees_into_structrefs_and_generators(component):
    with pytest.raises(AssertionError, match=r"greed=1\.0"):
        check_compiled_form_covers_params(component)


def test_compiled_forms_of_one_configuration_are_the_same():
    from conjure.domains import GymnasiumDomain, PersistentSurveillance
    from conjure.testing.checks import _form_content as form
    from conjure.testing.checks import _same

    components = [
        OnlineIFDD(base=Tabular()),  # a structref of tables
        MonteCarloRiskAnalyzer(),  # a Generator
        PersistentSurveillance(),  # scratch uniforms
        GymnasiumDomain(env_id="CartPole-v1"),  # a callback key per domain object
    ]
    for component in components:
        assert _same(form(component), form(component)), component
    assert not _same(form(GymnasiumDomain(env_id="CartPole-v1")), form(PersistentSurveillance()))
