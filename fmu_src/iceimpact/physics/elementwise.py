"""The C library's exp, expm1, log1p, sin, cos, sinh and cosh, element by element over arrays.

numpy's own ufuncs for these functions have variants per SIMD level: on a CPU with AVX-512 they
give other last bits than on one without (docs/explanation/accuracy.md#machine-independence). The
closed
forms evaluated over arrays (a sampled run, the grid of method 2) use these functions instead:
each element is Python's :mod:`math` function of it, the same value the scalar closed forms
give, on every CPU. They cost some 45 ns an element against numpy's 1 to 5; the callers
evaluate a function only on the elements that use its value.

Each function takes a float or an array and returns an array of its shape (0-d for a float).
Where :mod:`math` refuses an element (an overflow, a domain error: ``exp(1000)``,
``sin(inf)``), that element is numpy's, with numpy's warning: an infinity or a NaN, the same on
every CPU.

Where numba is installed (and ``ICEIMPACT_PURE`` unset) the loop over the elements is compiled
(:func:`_map`): numba's ``math`` functions call the same C library, so each element is the
same float, at a few ns instead of 45. An array with an element that is not finite goes the
Python way, so that the refused elements and their warnings stay as described.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable
from typing import Any

import numpy as np

from ..compiled import compile_or_none, entry_point, jit

__all__ = ["cos", "cosh", "exp", "expm1", "log1p", "sin", "sinh"]


#: the function :func:`_map` applies: each compiled copy is given its own in its place
_f: Callable[[float], float] = math.exp


def _map(x: np.ndarray, out: np.ndarray) -> bool:
    """out[i] = _f(x[i]), compiled by numba for each function ``_f`` (:func:`_compile`);
    whether every element is finite."""
    finite = True
    for i in range(x.shape[0]):
        r = _f(x[i])
        out[i] = r
        if not (r - r == 0.0):  # (inf or NaN)
            finite = False
    return finite


def _compile(numba: Any) -> dict[str, Callable[[np.ndarray, np.ndarray], bool]]:
    """:func:`_map` compiled for each function by name."""
    f8 = numba.float64[::1]
    loops = {}
    for name in __all__:
        copy = types.FunctionType(_map.__code__, _map.__globals__, f"_map_{name}")
        copy.__qualname__ = f"_map_{name}"  # (numba's cache: one entry per function)
        loops[name] = entry_point(jit(numba, (f8, f8), copy, _f=getattr(math, name)))
    return loops


_COMPILED = compile_or_none("the element-wise math functions", _compile)


def _elementwise(scalar: Callable[[float], float],
                 ufunc: np.ufunc) -> Callable[[np.ndarray | float], np.ndarray]:
    loop = None if _COMPILED is None else _COMPILED[scalar.__name__]

    def apply(x: np.ndarray | float) -> np.ndarray:
        a = np.asarray(x, dtype=float)
        if loop is not None:
            flat_array = np.ascontiguousarray(a.ravel())
            out = np.empty(flat_array.shape[0])
            if loop(flat_array, out):
                return out.reshape(a.shape)
        flat = a.ravel().tolist()
        try:
            values = np.fromiter(map(scalar, flat), float, len(flat))
        except (OverflowError, ValueError):
            values = np.array([_refused(scalar, ufunc, v) for v in flat], dtype=float)
        return values.reshape(a.shape)

    apply.__name__ = apply.__qualname__ = scalar.__name__
    apply.__doc__ = (f"``math.{scalar.__name__}`` of each element (an array of x's shape), "
                     f"numpy's ``{ufunc.__name__}`` where math refuses one.")
    return apply


def _refused(scalar: Callable[[float], float], ufunc: np.ufunc, value: float) -> float:
    try:
        return scalar(value)
    except (OverflowError, ValueError):
        return float(ufunc(value))


exp = _elementwise(math.exp, np.exp)
expm1 = _elementwise(math.expm1, np.expm1)
log1p = _elementwise(math.log1p, np.log1p)
sin = _elementwise(math.sin, np.sin)
cos = _elementwise(math.cos, np.cos)
sinh = _elementwise(math.sinh, np.sinh)
cosh = _elementwise(math.cosh, np.cosh)
