"""The contract between a component and the compiled learning loop (`conjure.compiled`).

A component with a numba kernel exposes it through one public method, ``compiled_form()``,
that returns a named tuple of typed fields (its constants, and the arrays its kernel updates in
place) which its own layer's kernels read by name; the compiled loop only composes those
kernels. A component without one returns None (the run takes the Python path).

Two class attributes complete the contract:

- ``compiled_methods``: the Python methods the kernel stands in for (a domain's ``step`` and
  ``reset``). `compiled_form` below answers None when a subclass overrides one of them, so a
  user's subclass never has its override skipped silently.
- ``compiled_irrelevant_params``: the ``get_params()`` keys the kernel does not need (for
  example a parameter only ``setup`` reads, already folded into the tables). The shipped common
  check `conjure.testing.checks.check_compiled_form_covers_params` asserts that changing any
  other key changes the compiled form.

A compiled call reads the forms' arrays through `borrowed` views: numba counts a reference
each time a kernel binds a form (every array of a named tuple, at every inlined call), with
an atomic add on the array's memory record, and in a loop as large as the learning loop its
pruning pass removes few of those pairs (about 70 atomic operations a step on the pendulum).
A view without a memory record is never counted.
"""

from __future__ import annotations

import functools
from typing import Any

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["borrowed", "compiled_form", "release"]


def compiled_form(component: Any) -> Any | None:
    """``component.compiled_form()``, or None when it has none or a subclass overrode its kernel.

    Examples
    --------
    >>> from conjure.policies import EpsilonGreedy
    >>> compiled_form(EpsilonGreedy(epsilon=0.2)).parameter
    0.2
    >>> class Mine(EpsilonGreedy):
    ...     def select(self, values, rng, legal_actions):
    ...         return 0
    >>> compiled_form(Mine()) is None
    True
    """
    method = getattr(component, "compiled_form", None)
    if method is None:
        return None
    cls = type(component)
    owner = _owner(cls, "compiled_form")
    for name in getattr(component, "compiled_methods", ()):
        if not issubclass(owner, _owner(cls, name)):
            return None  # overridden below the class whose kernel stands in for it
    return method()


@functools.cache
def _owner(cls: type, name: str) -> type:
    """The class of ``cls``'s method resolution order that defines ``name`` (asked per call)."""
    return next(klass for klass in cls.__mro__ if name in vars(klass))


@intrinsic
def borrowed(typingctx, value):
    """``value`` with each array (in nested tuples too) and generator seen without its owner.

    For a compiled function's own arguments: the caller holds them for the whole call, so the
    views need no reference counting (numba skips an array or generator whose memory record is
    null). Other members are passed on as they are (a structref keeps its one count). A view
    must not outlive the call (not stored in a structref, not returned).
    """

    def codegen(context, builder, signature, args):
        return _borrow(context, builder, signature.args[0], args[0])

    return value(value), codegen


@intrinsic
def release(typingctx, owners):
    """Nothing, but ``owners`` live until here: a function's own arrays seen `borrowed`.

    numba frees an array after its last use; borrowed views of a function's own arrays stay
    valid while their owners are passed here after the views' last use.
    """

    def codegen(context, builder, signature, args):
        return context.get_dummy_value()

    return types.none(owners), codegen


def _borrow(context: Any, builder: ir.IRBuilder, kind: types.Type, value: ir.Value) -> ir.Value:
    """`borrowed`'s code: null memory records, member by member."""
    if isinstance(kind, (types.Array, types.NumPyRandomGeneratorType)):
        proxy = cgutils.create_struct_proxy(kind)(context, builder, value=value)
        proxy.meminfo = cgutils.get_null_value(proxy.meminfo.type)
        return proxy._getvalue()
    if isinstance(kind, types.BaseTuple):
        members = [
            _borrow(context, builder, member, builder.extract_value(value, i))
            for i, member in enumerate(kind)
        ]
        return context.make_tuple(builder, kind, members)
    context.nrt.incref(builder, kind, value)  # a new reference, as the intrinsic returns one
    return value
