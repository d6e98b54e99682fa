"""Core layer: interfaces, errors, parameters, seeding and step-size schedules.

Everything else in conjure imports from here; this layer imports nothing of conjure.
Importing it keys numba's cache of every conjure kernel on the sources the kernel may reach
(`conjure.core.kernel_cache`), before any kernel is defined.
"""

from conjure.core.errors import (
    ConjureError,
    DivergenceError,
    IncompatibleComponentsError,
    InvalidParameterError,
    NotSetUpError,
)
from conjure.core.interfaces import (
    Agent,
    Domain,
    DomainSpec,
    Expansion,
    Policy,
    Representation,
    SparseFeatures,
    Transition,
)
from conjure.core.kernel_cache import watch_numba
from conjure.core.params import Configurable
from conjure.core.schedules import (
    ConstantStepSize,
    EpisodicDecay,
    FeatureNormalizedDecay,
    StepSizeSchedule,
)

__all__ = [
    "Agent",
    "Configurable",
    "ConjureError",
    "ConstantStepSize",
    "DivergenceError",
    "Domain",
    "DomainSpec",
    "EpisodicDecay",
    "Expansion",
    "FeatureNormalizedDecay",
    "IncompatibleComponentsError",
    "InvalidParameterError",
    "NotSetUpError",
    "Policy",
    "Representation",
    "SparseFeatures",
    "StepSizeSchedule",
    "Transition",
]

watch_numba()  # none of the modules above loads numba; every kernel is defined later
