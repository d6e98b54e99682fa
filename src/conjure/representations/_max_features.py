"""The ``max_features`` cap of the adaptive representations: initial plus discovered features."""

from __future__ import annotations

import numbers
from typing import Any

from conjure.core.errors import InvalidParameterError
from conjure.core.params import Predicate

__all__ = ["MAX_FEATURES", "OPTIONAL_MAX_FEATURES", "check_max_features"]

_DESCRIPTION = "an int in [1, inf) counting all features, initial plus discovered"


def _is_cap(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= 1


#: A required cap on the total number of features (initial + discovered).
MAX_FEATURES = Predicate(_is_cap, _DESCRIPTION)
#: The same cap, or ``None`` for no cap.
OPTIONAL_MAX_FEATURES = Predicate(lambda v: v is None or _is_cap(v), f"{_DESCRIPTION}, or None")


def check_max_features(owner: str, max_features: int | None, num_initial: int, where: str) -> None:
    """Raise unless ``max_features`` (None: no cap) leaves room for the initial features.

    ``where`` says what the initial features are (``"BinaryIndicators on 'BlocksWorld(6)'"``).
    """
    if max_features is not None and max_features < num_initial:
        raise InvalidParameterError(
            f"`{owner}.max_features` counts all features, the initial ones included, so it must "
            f"be at least the {num_initial} initial features ({where}); got {max_features!r}. "
            f"For up to k discovered features use max_features = {num_initial} + k."
        )
