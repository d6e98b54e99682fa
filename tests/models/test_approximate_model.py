import numpy as np
import pytest

from conjure.core.errors import IncompatibleComponentsError, InvalidParameterError
from conjure.domains import GridWorld
from conjure.models.approximate_model import ApproximateModel, observe_moves


def _model(**params):
    domain = GridWorld(map_name="4x5", noise=0.0)
    return ApproximateModel(domain=domain, **params).setup(domain.domain_spec, seed=0)


def test_noise_estimate_follows_the_prior_weighted_formula():
    # Section 5.5.2 with the prior as w * eta0: (u + w eta0) / (m + w)
    model = _model(initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    s = np.array([0.0, 1.0])  # the 4x5 map's free cell right of the start
    for _ in range(30):
        model.update(s, 3, np.array([0.0, 2.0]))  # intended: right
    for _ in range(10):
        model.update(s, 3, np.array([0.0, 0.0]))  # pushed left instead
    assert model.num_moves_ == 40 and model.num_unintended_ == 10
    assert model.noise_ == pytest.approx((10 + 100 * 0.4) / (40 + 100))


def test_a_static_model_keeps_its_prior():
    model = _model(initial_noise=0.4, is_adaptive=False)
    model.update(np.array([1.0, 1.0]), 3, np.array([0.0, 1.0]))
    assert model.noise_ == 0.4


def test_initial_noise_defaults_to_the_domains():
    assert _model().noise_ == 0.0


def test_samples_use_the_estimated_noise():
    model = _model(initial_noise=1.0)
    rng = np.random.default_rng(0)
    s = np.array([0.0, 1.0])
    outcomes = {tuple(model.sample(s, 3, rng)[0]) for _ in range(200)}
    assert outcomes == {(0.0, 0.0), (0.0, 2.0)}  # eta = 1: a random feasible move
    assert tuple(model.nominal_next_state(s, 3)) == (0.0, 2.0)


def test_domain_at_noise_is_rebuilt_with_the_estimate():
    model = _model(initial_noise=0.25)
    assert model.domain_at_noise().noise == 0.25


def test_a_model_of_another_domain_is_refused():
    model = ApproximateModel(domain=GridWorld(map_name="gridworld1"))
    with pytest.raises(IncompatibleComponentsError, match="map or graph"):
        model.setup(GridWorld(map_name="4x5").domain_spec, seed=0)


def test_bad_parameters_are_refused():
    with pytest.raises(InvalidParameterError, match="prior_weight"):
        _model(prior_weight=-1.0)


def test_load_counts_restores_the_estimate():
    model = _model(initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    model.load_counts(num_unintended=5, num_moves=61)
    assert (model.num_unintended_, model.num_moves_) == (5, 61)
    assert model.noise_ == pytest.approx((5 + 40) / 161)
    static = _model(initial_noise=0.4)
    static.load_counts(0, 0)
    assert static.noise_ == 0.4


def test_a_kernels_update_of_the_form_is_the_models_estimate():
    # η̂ is kept once: the compiled form is the model's own arrays, so no load-back
    model = _model(initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    form = model.noise_model()
    assert form is model.noise_model()
    observe_moves(form, 1, 2)
    observe_moves(form, 0, 1)
    assert (model.num_unintended_, model.num_moves_) == (1, 3)
    assert model.noise_ == (1 + 100 * 0.4) / (3 + 100)
