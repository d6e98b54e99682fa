"""Models: exact tabular (P, R) models and generative samplers shared by planners (ch. 2)."""

from __future__ import annotations

from conjure.core.lazy import lazy_exports

#: Each public name and the submodule defining it, imported on first use.
_EXPORTS = {
    "enumerate_model": "enumerate",
    "DomainSampler": "generative",
    "GenerativeModel": "generative",
    "ModelSampler": "generative",
    "generative_model": "generative",
    "steady_state_distribution": "steady_state",
    "TabularModel": "tabular_model",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
