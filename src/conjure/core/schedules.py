"""Step-size (learning-rate) schedules α_t of the online learners.

Geramifard (2012) uses two decaying schedules: Section 4.1.4 (online iFDD experiments) and
Section 5.3.5 (iCCA experiments). Each schedule is a small `Configurable` whose ``value`` the
agent calls once per learning step with the current episode number and the number of active
features k_t.

The expressions are the module functions `feature_normalized_rate` and `episodic_rate`: the
schedules' ``value`` runs them in Python and the compiled loop runs the same source compiled
by numba (`conjure.agents._kernels.step_size`), so both paths round alike. ``compiled_form()``
gives a schedule's kind and constants (`ScheduleKernel`).
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

from conjure.core.params import Configurable, Interval

__all__ = [
    "ALPHA_0",
    "MAX_ALPHA_0",
    "ConstantStepSize",
    "EpisodicDecay",
    "FeatureNormalizedDecay",
    "ScheduleKernel",
    "StepSizeSchedule",
    "episodic_rate",
    "feature_normalized_rate",
]

#: The largest α_0 accepted. Choice: the thesis searched α_0 in {0.01, 0.1, 1} (Section 4.1.4);
#: with binary features a TD update by α_0 >= 2 on a single active feature overshoots its
#: target, so far beyond that a step size can only diverge.
MAX_ALPHA_0 = 10.0
#: α_0 of every schedule (and a learner's plain float step size): a float in (0, 10].
ALPHA_0 = Interval(float, 0, MAX_ALPHA_0, closed="right")

#: Schedule kinds of `ScheduleKernel`.
CONSTANT, FEATURE_NORMALIZED, EPISODIC = 0, 1, 2


class ScheduleKernel(NamedTuple):
    """A schedule as the compiled loop reads it: its kind, α_0 and N_0 (0 when unused)."""

    kind: int
    alpha_0: float
    n_0: float


def feature_normalized_rate(alpha_0: float, n_0: float, episode: int, num_active: float) -> float:
    """α_0 / k_t · (N_0 + 1) / (N_0 + episode^1.1), Section 4.1.4."""
    return alpha_0 / num_active * (n_0 + 1.0) / (n_0 + float(episode) ** 1.1)


def episodic_rate(alpha_0: float, n_0: float, episode: int) -> float:
    """α_0 (N_0 + 1) / (N_0 + episode), Section 5.3.5."""
    return alpha_0 * (n_0 + 1.0) / (n_0 + episode)


class StepSizeSchedule(Configurable):
    """A step size α_t as a function of the episode number and the active-feature count k_t.

    ``uses_num_active`` says whether α_t depends on k_t; learners skip computing k_t (the
    L1 norm of φ(s)) for schedules that ignore it and pass 1.
    """

    uses_num_active: ClassVar[bool] = True
    #: The method the compiled form stands in for (`conjure.core.compiled_form`).
    compiled_methods: ClassVar[tuple[str, ...]] = ("value",)

    def value(self, episode: int, num_active: float) -> float:
        """Return α_t for 1-based ``episode`` and ``num_active`` = k_t (> 0)."""
        raise NotImplementedError


class ConstantStepSize(StepSizeSchedule):
    """A constant step size α_t = α_0 (Algorithms 10-12 as written).

    Parameters
    ----------
    alpha_0 : float, default 0.1
        The step size α_0, in (0, 10] (`MAX_ALPHA_0`).

    Examples
    --------
    >>> ConstantStepSize(alpha_0=0.5).value(episode=10, num_active=4)
    0.5
    """

    parameter_constraints = {"alpha_0": ALPHA_0}
    uses_num_active = False

    def __init__(self, *, alpha_0: float = 0.1):
        self.alpha_0 = alpha_0

    def value(self, episode: int, num_active: float) -> float:
        """Return α_0."""
        return self.alpha_0

    def compiled_form(self) -> ScheduleKernel:
        """α_0 for the compiled loop."""
        return ScheduleKernel(kind=CONSTANT, alpha_0=float(self.alpha_0), n_0=0.0)


class FeatureNormalizedDecay(StepSizeSchedule):
    """α_t = α_0 / k_t · (N_0 + 1) / (N_0 + episode^1.1), Geramifard (2012), Section 4.1.4.

    Parameters
    ----------
    alpha_0 : float, default 0.1
        α_0 in (0, 10]; the thesis searched {0.01, 0.1, 1}.
    n_0 : float, default 1000
        N_0 in [0, inf); the thesis searched {100, 1000, 1e6}.

    Notes
    -----
    - k_t is the number of active features of the updated state. Choice: for dense features
      (Gaussian RBF) the agent passes the L1 norm of φ(s) (`Representation.encode`'s values),
      which equals k_t for binary ones.
    - Choice: ``episode`` counts from 1 (the first episode gives α_0 / k_t).

    Examples
    --------
    >>> FeatureNormalizedDecay(alpha_0=1.0, n_0=100).value(episode=1, num_active=4)
    0.25
    """

    parameter_constraints = {
        "alpha_0": ALPHA_0,
        "n_0": Interval(float, 0, None),
    }

    def __init__(self, *, alpha_0: float = 0.1, n_0: float = 1000.0):
        self.alpha_0 = alpha_0
        self.n_0 = n_0

    def value(self, episode: int, num_active: float) -> float:
        """Return α_0 / k_t · (N_0 + 1) / (N_0 + episode^1.1)."""
        return feature_normalized_rate(self.alpha_0, self.n_0, episode, num_active)

    def compiled_form(self) -> ScheduleKernel:
        """α_0 and N_0 for the compiled loop."""
        return ScheduleKernel(
            kind=FEATURE_NORMALIZED, alpha_0=float(self.alpha_0), n_0=float(self.n_0)
        )


class EpisodicDecay(StepSizeSchedule):
    """α_t = α_0 (N_0 + 1) / (N_0 + episode), Geramifard (2012), Section 5.3.5.

    Parameters
    ----------
    alpha_0 : float, default 0.1
        α_0 in (0, 10].
    n_0 : float, default 1000
        N_0 in [0, inf).

    Examples
    --------
    >>> EpisodicDecay(alpha_0=1.0, n_0=1.0).value(episode=3, num_active=7)
    0.5
    """

    parameter_constraints = {
        "alpha_0": ALPHA_0,
        "n_0": Interval(float, 0, None),
    }
    uses_num_active = False

    def __init__(self, *, alpha_0: float = 0.1, n_0: float = 1000.0):
        self.alpha_0 = alpha_0
        self.n_0 = n_0

    def value(self, episode: int, num_active: float) -> float:
        """Return α_0 (N_0 + 1) / (N_0 + episode)."""
        return episodic_rate(self.alpha_0, self.n_0, episode)

    def compiled_form(self) -> ScheduleKernel:
        """α_0 and N_0 for the compiled loop."""
        return ScheduleKernel(kind=EPISODIC, alpha_0=float(self.alpha_0), n_0=float(self.n_0))
