import pytest

from conjure.core import ConstantStepSize, EpisodicDecay, FeatureNormalizedDecay


def test_feature_normalized_decay_section_4_1_4():
    schedule = FeatureNormalizedDecay(alpha_0=0.1, n_0=100)
    assert schedule.value(1, 10) == pytest.approx(0.01)
    expected = 0.1 / 4 * 101 / (100 + 50**1.1)
    assert schedule.value(50, 4) == pytest.approx(expected)


def test_episodic_decay_section_5_3_5_halves_at_n0_plus_one():
    schedule = EpisodicDecay(alpha_0=1.0, n_0=1000)
    assert schedule.value(1, 3) == pytest.approx(1.0)
    assert schedule.value(1002, 3) == pytest.approx(0.5)


def test_constant_ignores_episode_and_features():
    assert ConstantStepSize(alpha_0=0.3).value(10**6, 100) == 0.3
