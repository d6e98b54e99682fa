"""`compiled_form`: a kernel is used only where no subclass overrode what it stands for."""

from conjure.core.compiled_form import compiled_form
from conjure.core.schedules import ConstantStepSize
from conjure.domains import ChainMDP
from conjure.planners import ValueIteration
from conjure.policies import Gibbs


class _Chain(ChainMDP):
    """Overrides ``step``: a compiled loop would skip the override."""

    def step(self, action):
        return super().step(action)


class _Renamed(ChainMDP):
    """Overrides nothing the kernel stands for."""


class _Schedule(ConstantStepSize):
    def value(self, episode, num_active):
        return 2 * self.alpha_0


def test_a_component_gives_its_own_form():
    assert compiled_form(Gibbs(temperature=0.5)).parameter == 0.5
    assert compiled_form(ConstantStepSize(alpha_0=0.3)).alpha_0 == 0.3


def test_an_overridden_kernel_method_gives_no_form():
    assert compiled_form(_Chain()) is None
    assert compiled_form(_Schedule()) is None


def test_a_subclass_that_overrides_nothing_keeps_the_form():
    assert compiled_form(_Renamed(num_states=5)).chain.num_states == 5


def test_a_component_without_a_kernel_gives_none():
    assert compiled_form(ValueIteration()) is None
