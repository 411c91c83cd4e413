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
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["cos", "cosh", "exp", "expm1", "log1p", "sin", "sinh"]


def _elementwise(scalar: Callable[[float], float],
                 ufunc: np.ufunc) -> Callable[[np.ndarray | float], np.ndarray]:
    def apply(x: np.ndarray | float) -> np.ndarray:
        a = np.asarray(x, dtype=float)
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
