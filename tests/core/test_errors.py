from conjure.core import (
    ConjureError,
    DivergenceError,
    IncompatibleComponentsError,
    InvalidParameterError,
    NotSetUpError,
)


def test_hierarchy_keeps_builtin_bases():
    assert issubclass(InvalidParameterError, ValueError)
    assert issubclass(NotSetUpError, RuntimeError)
    assert issubclass(IncompatibleComponentsError, TypeError)
    assert issubclass(DivergenceError, ArithmeticError)
    for error in (
        InvalidParameterError,
        NotSetUpError,
        IncompatibleComponentsError,
        DivergenceError,
    ):
        assert issubclass(error, ConjureError)
