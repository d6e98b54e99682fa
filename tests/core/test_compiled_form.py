"""`compiled_form`: a kernel is used only where no subclass overrode what it stands for."""

import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from conjure.core.compiled_form import borrowed, compiled_form, release
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


class _Form(NamedTuple):
    """A form with arrays, a scalar, a nested tuple and a generator."""

    weights: np.ndarray
    count: int
    nested: tuple[np.ndarray, np.ndarray]
    rng: np.random.Generator


@njit
def _update_borrowed(form: _Form, times: int) -> float:
    form = borrowed(form)
    total = 0.0
    for _ in range(times):
        form.weights[0] += 1.0
        form.nested[1][0] += form.count
        total += form.rng.random()
    return total


def test_borrowed_views_write_through_and_leave_reference_counts_alone():
    weights, extra = np.zeros(3), np.zeros(2)
    form = _Form(weights, 2, (np.ones(1), extra), np.random.default_rng(5))
    before = sys.getrefcount(weights), sys.getrefcount(extra)
    total = _update_borrowed(form, 4)
    assert weights[0] == 4.0 and extra[0] == 8.0
    assert total == np.random.default_rng(5).random(4).sum()  # the generator's own state
    assert (sys.getrefcount(weights), sys.getrefcount(extra)) == before


@njit
def _sum_of_own_scratch(n: int) -> float:
    first, second = np.zeros(n), np.ones(n)
    owners = (first, second)
    first, second = borrowed(owners)
    for i in range(n):
        first[i] = second[i] + i
    total = first.sum()
    release(owners)
    return total


def test_borrowed_views_of_a_functions_own_arrays_live_until_release():
    assert _sum_of_own_scratch(1000) == 1000 + 999 * 1000 / 2
