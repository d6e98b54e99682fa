"""Shipped checks for conjure components (and users' own), as Gymnasium's ``check_env``."""

from conjure.testing.checks import applicable_checks, box_spec, check_component, sample_states

__all__ = ["applicable_checks", "box_spec", "check_component", "sample_states"]
