import pytest

from conjure.core import Configurable, InvalidParameterError
from conjure.core.params import InstanceOf, Interval, Options, Predicate, did_you_mean


class Inner(Configurable):
    parameter_constraints = {"rate": Interval(float, 0, 1, closed="right")}

    def __init__(self, *, rate: float = 0.5):
        self.rate = rate


class Outer(Configurable):
    parameter_constraints = {
        "inner": InstanceOf(Inner),
        "mode": Options(("fast", "exact")),
        "size": Interval(int, 1, None) | InstanceOf(type(None)),
    }

    def __init__(self, *, inner: Inner, mode: str = "fast", size: int | None = None):
        self.inner = inner
        self.mode = mode
        self.size = size


def test_interval_bounds_and_types():
    half_open = Interval(float, 0, 1, closed="right")
    assert half_open.describe() == "a float in (0, 1]"
    assert not half_open.is_satisfied_by(0.0) and half_open.is_satisfied_by(1)
    assert not half_open.is_satisfied_by(True) and not half_open.is_satisfied_by(float("nan"))
    assert not Interval(int, 0, None).is_satisfied_by(1.5)


def test_error_message_names_class_field_value_and_expectation():
    with pytest.raises(InvalidParameterError) as error:
        Inner(rate=-0.1).validate_params()
    assert str(error.value) == "`Inner.rate` must be a float in (0, 1]; got -0.1."
    with pytest.raises(InvalidParameterError, match="one of 'fast', 'exact'; got 'slow'"):
        Outer(inner=Inner(), mode="slow").validate_params()


def test_deep_params_set_params_and_did_you_mean():
    outer = Outer(inner=Inner(rate=0.2), size=3)
    assert outer.get_params(deep=True)["inner__rate"] == 0.2
    outer.set_params(inner__rate=0.7, mode="exact")
    assert outer.inner.rate == 0.7 and outer.mode == "exact"
    with pytest.raises(InvalidParameterError, match="Did you mean 'mode'"):
        outer.set_params(mdoe="fast")
    assert did_you_mean("sarsa_lamda", ["sarsa_lambda", "q"]) == " Did you mean 'sarsa_lambda'?"


def test_clone_is_deep_equal_and_repr_shows_non_defaults():
    outer = Outer(inner=Inner(rate=0.2), size=3)
    twin = outer.clone()
    assert twin == outer and twin.inner is not outer.inner
    assert repr(outer) == "Outer(inner=Inner(rate=0.2), size=3)"
    assert Predicate(lambda v: v > 0, "positive").is_satisfied_by("x") is False
