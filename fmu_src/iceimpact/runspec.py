"""A run described as text: parameter changes by FMI name (``NAME=VALUE``), numbers read from
the command line, the default sample step and the largest run the commands accept.

Shared by ``iceimpact simulate`` and the sweep package (which parses its grids with the same
rules), below both: it depends on :mod:`iceimpact.scene` only. Errors raise :class:`SpecError`
(a ValueError) whose message names the argument, the value and what is expected.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from typing import Any

from .errors import real_number, value_text
from .scene import FLOW_INPUT, PARAMETERS, SPECS_BY_NAME, Scene

#: Default sample step of the command-line runs and sweeps, s: 125 samples per natural period of
#: the Figure 2 structure (4 Hz) and a Nyquist frequency of 250 Hz for the spectrum; sampling
#: dominates the cost of a run, which is proportional to t_end / dt (see docs/explanation/speed.md).
DEFAULT_DT = 2e-3

#: Most samples (t_end / dt) of one run: a run stores about 60 bytes per sample, so this is
#: about 1.2 GB; more is refused before anything is allocated (raise dt or lower t_end).
MAX_SAMPLES = 20_000_000

#: Integer parameters are kept as Python ints up to here (exactly representable as a float);
#: beyond, a value such as 1e30 stays a float, so that error messages print it as 1e+30.
_EXACT_INT = 2**53

Value = float | int


class SpecError(ValueError):
    """A malformed ``NAME=VALUE``, an unknown name or a number that is not a finite number."""


def parameter_names() -> list[str]:
    """FMI names a run can change: every parameter of :data:`PARAMETERS` and ``flow.u``."""
    return [p.name for p in PARAMETERS] + [FLOW_INPUT.name]


def suggest(name: str, names: list[str]) -> list[str]:
    """Up to three of ``names`` that look like ``name`` (case ignored), best first."""
    by_lower = {n.lower(): n for n in names}
    close = difflib.get_close_matches(name.lower(), list(by_lower), n=3, cutoff=0.6)
    return [by_lower[c] for c in close]


def check_name(name: str, what: str) -> None:
    """SpecError naming ``what`` unless ``name`` is an FMI name of :func:`parameter_names`;
    the message suggests the closest names ("did you mean ...") and lists all of them."""
    if name in SPECS_BY_NAME:
        return
    names = parameter_names()
    close = suggest(name, names)
    hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
    raise SpecError(f"{what}: unknown parameter {shown(name)}{hint}; known: "
                    + ", ".join(known_names(names)))


def known_names(names: list[str]) -> list[str]:
    """``names`` as an error lists them: the modes' parameters (structure.mode1.f to
    structure.mode5.v0) as one entry, so that the list stays readable."""
    out: list[str] = []
    fields: list[str] = []
    modes: set[int] = set()
    for name in names:
        prefix, _, field = name.rpartition(".")
        k = prefix[len("structure.mode"):]
        if prefix.startswith("structure.mode") and k.isdigit():
            if not fields:
                out.append("")  # the modes' place in the list, filled below
            if field not in fields:
                fields.append(field)
            modes.add(int(k))
        else:
            out.append(name)
    if fields:
        out[out.index("")] = (f"structure.mode<k>.{{{', '.join(fields)}}} "
                              f"(k = {min(modes)} to {max(modes)})")
    return out


def parse_number(text: str, what: str) -> float:
    """A finite float from ``text``; SpecError naming ``what`` otherwise (1e400 overflows to
    inf and is refused like inf and nan)."""
    try:
        value = float(text)
    except ValueError:
        raise SpecError(f"{what}: {shown(text.strip())} is not a number") from None
    if not math.isfinite(value):
        raise SpecError(f"{what}: {shown(text.strip())} is not finite (|value| must be below "
                        f"{float.fromhex('0x1.fffffffffffffp+1023'):.4g})")
    return value


def coerce(name: str, value: Any) -> Value:
    """A value for the FMI name ``name`` as a Python number: int for integer parameters when
    integral (and not huge), else float. Non-numbers and non-finite numbers raise
    :class:`SpecError`; other out-of-range numbers are left to the scene's validation."""
    number = real_number(value)  # Python and numpy numbers alike (an absurd integer: inf)
    if number is None:
        raise SpecError(f"{name}: value {value!r} is not a number")
    if not math.isfinite(number):  # no parameter accepts it; nan would also defeat resuming
        raise SpecError(f"{name}: value {value_text(value)} is not finite")
    if SPECS_BY_NAME[name].kind is int and number == int(number) and abs(number) < _EXACT_INT:
        return int(number)
    return number


def shown(spec: str, limit: int = 60) -> str:
    """``spec`` quoted for an error message, shortened in the middle if longer than ``limit``."""
    if len(spec) > limit:
        spec = f"{spec[:limit - 20]}...({len(spec):,} characters)...{spec[-10:]}"
    return repr(spec)


def parse_set(spec: str) -> tuple[str, Value]:
    """``NAME=VALUE`` -> (FMI name, number), a fixed change of the base scene."""
    what = f"--set {shown(spec)}"
    name, sep, rhs = spec.partition("=")
    name = name.strip()
    if not sep or not name:
        raise SpecError(f"{what}: expected NAME=VALUE")
    check_name(name, what)
    try:
        return name, coerce(name, parse_number(rhs, what))
    except OverflowError:  # pragma: no cover - parse_number refuses inf first
        raise SpecError(f"{what}: the value overflows") from None


def apply(base: Scene, params: Mapping[str, Value]) -> Scene:
    """``base`` with FMI-named parameters replaced (validated: may raise ParameterError)."""
    return base.replace_fmi(dict(params))


def check_samples(t_end: float, dt: float) -> None:
    """SpecError when a run of ``t_end`` s sampled every ``dt`` s would hold more than
    :data:`MAX_SAMPLES` samples (or the ratio overflows)."""
    n = t_end / dt
    if not math.isfinite(n) or n > MAX_SAMPLES:
        raise SpecError(f"t_end / dt = {t_end:g} / {dt:g} = {n:.3g} samples per run, more than "
                        f"the {MAX_SAMPLES:,} a run may hold (about 60 bytes each); raise --dt "
                        "or lower --t-end")
