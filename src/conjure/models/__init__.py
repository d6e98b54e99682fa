"""Models: exact tabular (P, R) models and generative samplers shared by planners (ch. 2)."""

from conjure.models.enumerate import enumerate_model
from conjure.models.generative import DomainSampler, GenerativeModel, ModelSampler, generative_model
from conjure.models.steady_state import steady_state_distribution
from conjure.models.tabular_model import TabularModel

__all__ = [
    "DomainSampler",
    "GenerativeModel",
    "ModelSampler",
    "TabularModel",
    "enumerate_model",
    "generative_model",
    "steady_state_distribution",
]
