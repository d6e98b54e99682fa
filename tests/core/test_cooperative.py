import numpy as np
import pytest

from conjure.core.cooperative import CooperativePlanner, NoisyDomain, RiskAnalyzer
from conjure.core.interfaces import Domain
from conjure.domains import GridWorld


def test_domains_are_unconstrained_unless_they_say_otherwise():
    assert Domain.is_constrained(GridWorld(), np.array([2.0, 0.0])) is False  # the default
    grid = GridWorld()  # GridWorld-1: pits at (2, 0) and (6, 2)
    assert grid.is_constrained(np.array([2.0, 0.0]))
    assert not grid.is_constrained(np.array([0.0, 0.0]))


def test_noisy_domain_names_its_noise_parameter():
    grid = GridWorld(noise=0.3)
    assert isinstance(grid, NoisyDomain)
    assert grid.noise_level == 0.3


def test_abstract_methods_raise():
    with pytest.raises(NotImplementedError):
        CooperativePlanner().action(np.zeros(1))
    with pytest.raises(NotImplementedError):
        RiskAnalyzer().risk(np.zeros(1), 0)
    assert CooperativePlanner().update(None) is False
