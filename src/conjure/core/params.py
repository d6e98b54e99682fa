"""Parameters of every component: declaration, validation, get/set, clone and repr.

The lifecycle follows scikit-learn's estimator contract: a constructor is keyword-only and only
stores its arguments; ``setup`` (or ``validate_params``) checks them against the constraints the
class declares in ``parameter_constraints``; learned state ends in ``_``.
"""

from __future__ import annotations

import copy
import difflib
import inspect
import math
import numbers
from collections.abc import Callable, Iterable
from typing import Any, ClassVar

from conjure.core.errors import InvalidParameterError

__all__ = [
    "EPISODE_STEPS",
    "INT_MAX",
    "NEXT_SAMPLES",
    "SAMPLES",
    "AnyOf",
    "Configurable",
    "Constraint",
    "InstanceOf",
    "Interval",
    "Options",
    "Predicate",
    "did_you_mean",
]


#: The largest int an `Interval` without an upper bound accepts: what an int64 array holds.
INT_MAX = 2**63 - 1


class Constraint:
    """A rule a parameter value must satisfy; ``describe`` reads as 'a float in (0, 1]'."""

    def is_satisfied_by(self, value: Any) -> bool:
        """Return whether ``value`` satisfies the rule."""
        raise NotImplementedError

    def describe(self) -> str:
        """Return the rule as a noun phrase for error messages."""
        raise NotImplementedError

    def __or__(self, other: Constraint) -> Constraint:
        return AnyOf((self, other))


class AnyOf(Constraint):
    """Any of several rules: what ``rule_a | rule_b`` builds."""

    def __init__(self, options: tuple[Constraint, ...]):
        self.options = options

    def is_satisfied_by(self, value: Any) -> bool:
        return any(option.is_satisfied_by(value) for option in self.options)

    def describe(self) -> str:
        return " or ".join(option.describe() for option in self.options)

    def __or__(self, other: Constraint) -> Constraint:
        return AnyOf((*self.options, other))


class Interval(Constraint):
    """A real or integer number in an interval; ``closed`` is 'both', 'left', 'right' or 'neither'.

    A missing bound is open, so it excludes infinity: ``Interval(float, 0, None)`` prints
    ``[0, inf)`` and refuses ``inf``; ``Interval(float, 0, math.inf)`` prints ``[0, inf]`` and
    accepts it. An int without an upper bound must fit an int64
    (`INT_MAX`, printed ``2^63``); a component whose count drives a loop or an allocation
    declares its own, smaller bound.

    Examples
    --------
    >>> Interval(float, 0, 1, closed="right").describe()
    'a float in (0, 1]'
    >>> Interval(int, 1, None).is_satisfied_by(3)
    True
    """

    def __init__(
        self,
        kind: type,
        low: float | None,
        high: float | None,
        *,
        closed: str = "both",
    ):
        self.kind, self.low, self.high, self.closed = kind, low, high, closed

    def is_satisfied_by(self, value: Any) -> bool:
        if isinstance(value, bool):
            return False
        wanted = numbers.Integral if self.kind is int else numbers.Real
        if not isinstance(value, wanted) or (self.kind is float and math.isnan(value)):
            return False
        if self.kind is float and math.isinf(value):  # only at a bound that is infinite, closed
            bound, closed = (self.high, "right") if value > 0 else (self.low, "left")
            return bound == value and self.closed in ("both", closed)
        if self.kind is int and self.high is None and not -INT_MAX - 1 <= value <= INT_MAX:
            return False
        if self.low is not None:
            if value < self.low or (value == self.low and self.closed in ("right", "neither")):
                return False
        if self.high is not None:
            if value > self.high or (value == self.high and self.closed in ("left", "neither")):
                return False
        return True

    def describe(self) -> str:
        noun = "an int" if self.kind is int else "a float"
        if self.low is None and self.high is None:
            return noun
        left = "[" if self.closed in ("both", "left") and self.low is not None else "("
        right = "]" if self.closed in ("both", "right") and self.high is not None else ")"
        low = "-inf" if self.low is None else f"{self.low:g}"
        high = ("2^63" if self.kind is int else "inf") if self.high is None else f"{self.high:g}"
        return f"{noun} in {left}{low}, {high}{right}"


class Options(Constraint):
    """One of a fixed set of values."""

    def __init__(self, options: Iterable[Any]):
        self.options = tuple(options)

    def is_satisfied_by(self, value: Any) -> bool:
        return any(value == option and type(value) is type(option) for option in self.options)

    def describe(self) -> str:
        return "one of " + ", ".join(repr(option) for option in self.options)


class InstanceOf(Constraint):
    """An instance of a type (``None`` allowed with ``InstanceOf(type(None))``)."""

    def __init__(self, kind: type | tuple[type, ...], description: str | None = None):
        self.kind = kind
        self.description = description

    def is_satisfied_by(self, value: Any) -> bool:
        return isinstance(value, self.kind)

    def describe(self) -> str:
        if self.description is not None:
            return self.description
        kinds = self.kind if isinstance(self.kind, tuple) else (self.kind,)
        names = [k.__name__ for k in kinds if k is not type(None)]
        described = ["an instance of " + " or ".join(names)] if names else []
        return " or ".join(described + (["None"] if type(None) in kinds else []))


class Predicate(Constraint):
    """Any rule given as a function and its description."""

    def __init__(self, check: Callable[[Any], bool], description: str):
        self.check, self.description = check, description

    def is_satisfied_by(self, value: Any) -> bool:
        try:
            return bool(self.check(value))
        except (TypeError, ValueError):
            return False

    def describe(self) -> str:
        return self.description


#: Sense bounds on counts that size a loop or an array (Choice: far above any thesis setting,
#: well below what would run for hours or allocate gigabytes). A horizon bounds each greedy
#: policy check, which may never end an episode before it.
EPISODE_STEPS = Interval(int, 1, 10**6)
#: Samples a sampled planner draws per iteration (Algorithms 5-9: the thesis used hundreds).
SAMPLES = Interval(int, 1, 10**7)
#: Next states drawn per sampled state-action pair (the thesis used 1).
NEXT_SAMPLES = Interval(int, 1, 10**4)


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """Return ' Did you mean 'x'?' for the closest known name, or an empty string."""
    matches = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f" Did you mean {matches[0]!r}?" if matches else ""


class Configurable:
    """Base of every component: declared parameters with get/set, clone, validation and repr.

    Subclasses write a keyword-only ``__init__`` that stores each argument under its own name
    and declare ``parameter_constraints = {name: Constraint}``.

    Examples
    --------
    >>> class Thing(Configurable):
    ...     parameter_constraints = {"size": Interval(int, 1, None)}
    ...     def __init__(self, *, size: int = 3):
    ...         self.size = size
    >>> Thing(size=4)
    Thing(size=4)
    >>> Thing(size=0).validate_params()
    Traceback (most recent call last):
    ...
    conjure.core.errors.InvalidParameterError: `Thing.size` must be an int in [1, 2^63); got 0.
    """

    parameter_constraints: ClassVar[dict[str, Constraint]] = {}
    expected_check_failures: ClassVar[dict[str, str]] = {}

    @classmethod
    def param_names(cls) -> list[str]:
        """Return the names of the constructor's parameters, in declaration order."""
        signature = inspect.signature(cls.__init__)
        return [
            p.name
            for p in signature.parameters.values()
            if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]

    @classmethod
    def param_defaults(cls) -> dict[str, Any]:
        """Return the constructor's default value of each parameter (``inspect._empty`` if none)."""
        signature = inspect.signature(cls.__init__)
        return {name: signature.parameters[name].default for name in cls.param_names()}

    def get_params(self, deep: bool = False) -> dict[str, Any]:
        """Return the parameters; with ``deep`` also nested ones as ``outer__inner`` keys."""
        params = {name: getattr(self, name) for name in self.param_names()}
        if deep:
            for name, value in list(params.items()):
                if isinstance(value, Configurable):
                    for inner, inner_value in value.get_params(deep=True).items():
                        params[f"{name}__{inner}"] = inner_value
        return params

    def set_params(self, **params: Any) -> Configurable:
        """Set parameters (``outer__inner`` reaches nested components) and return ``self``."""
        known = self.param_names()
        for key, value in params.items():
            name, _, rest = key.partition("__")
            if name not in known:
                raise InvalidParameterError(
                    f"{type(self).__name__} has no parameter {name!r}."
                    f"{did_you_mean(name, known)} Known: {', '.join(known)}."
                )
            if rest:
                inner = getattr(self, name)
                if not isinstance(inner, Configurable):
                    raise InvalidParameterError(
                        f"`{type(self).__name__}.{name}` is not a component; cannot set {key!r}."
                    )
                inner.set_params(**{rest: value})
            else:
                setattr(self, name, value)
        return self

    def clone(self) -> Configurable:
        """Return a new, not-set-up component with equal parameters (nested ones cloned)."""
        params = {}
        for name, value in self.get_params().items():
            is_component = isinstance(value, Configurable)
            params[name] = value.clone() if is_component else copy.deepcopy(value)
        return type(self)(**params)

    def validate_params(self) -> None:
        """Check every declared parameter and raise `InvalidParameterError` naming the bad one."""
        for name, constraint in self.parameter_constraints.items():
            value = getattr(self, name)
            if not constraint.is_satisfied_by(value):
                raise InvalidParameterError(
                    f"`{type(self).__name__}.{name}` must be {constraint.describe()}; "
                    f"got {value!r}."
                )

    def __repr__(self) -> str:
        defaults = self.param_defaults()
        shown = []
        for name, value in self.get_params().items():
            default = defaults.get(name, inspect.Parameter.empty)
            if _differs(value, default):
                shown.append(f"{name}={value!r}")
        return f"{type(self).__name__}({', '.join(shown)})"

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        mine, theirs = self.get_params(), other.get_params()
        return all(not _differs(mine[k], theirs[k]) for k in mine)

    __hash__ = object.__hash__


def _differs(value: Any, default: Any) -> bool:
    if default is inspect.Parameter.empty:
        return True
    try:
        return bool(value != default)
    except (TypeError, ValueError):  # arrays and other objects without a scalar ==
        return value is not default
