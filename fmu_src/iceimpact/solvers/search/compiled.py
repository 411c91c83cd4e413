"""numba for the searches' kernels: whether they are compiled, and how.

A kernel is a function over plain floats and arrays that runs as Python as it is, and compiled
by numba where numba is installed (the ``fast`` extra) and ``ICEIMPACT_PURE`` is not set in the
environment. numba compiles it without ``fastmath`` (no contraction of a product and a sum into
one fused operation, no reordering), and its ``math`` functions call the same C library as
CPython's, so the compiled kernel gives the same floats as the pure one.
"""

from __future__ import annotations

import os
import types
import warnings
from collections.abc import Callable
from typing import Any


def numba_or_none() -> Any:
    """The numba module, or None where it is not installed or ``ICEIMPACT_PURE`` is set."""
    if os.environ.get("ICEIMPACT_PURE", "") not in ("", "0"):
        return None
    try:
        import numba
    except ImportError:
        return None
    return numba


def jit(numba: Any, signature: Any, function: Callable, **callees: Any) -> Any:
    """``function`` compiled for its one signature (at once, its machine code cached in
    ``__pycache__`` for later imports), the functions it calls by the names in ``callees``
    replaced by their compiled forms (the module's names keep the pure ones)."""
    copy = types.FunctionType(function.__code__, {**function.__globals__, **callees},
                              function.__name__)
    copy.__qualname__ = function.__qualname__
    return numba.njit(signature, cache=True, fastmath=False, error_model="python")(copy)


def entry_point(dispatcher: Any) -> Callable:
    """The compiled function of a one-signature dispatcher, called without the dispatcher's
    matching of argument types (the caller passes the signature's types)."""
    return dispatcher.overloads[dispatcher.signatures[0]].entry_point


def not_compiled(what: str, exc: Exception) -> None:
    """Say that numba failed on ``what``: the pure path runs."""
    warnings.warn(f"numba could not compile {what} ({exc}); the pure path runs (the same "
                  "results, slower)", RuntimeWarning, stacklevel=3)


def compile_or_none(what: str, build: Callable[[Any], Any]) -> Any:
    """``build(numba)``: the compiled kernels of a module, or None where numba is not installed,
    ``ICEIMPACT_PURE`` is set, or numba fails on them (said once, :func:`not_compiled`): the
    pure path runs."""
    numba = numba_or_none()
    if numba is None:
        return None
    try:
        return build(numba)
    except Exception as exc:  # (any failure of numba leaves the pure path)
        not_compiled(what, exc)
        return None
