"""Time series in OpenFAST's text output format (``.out``), for the tools engineers already use.

pCrunch, openfast-io (``FASTOutputFile``) and pyDatView (openfast_toolbox / weio) read an
IceImpact run written here as they read an OpenFAST run. The layout is the one OpenFAST writes
with ``TabDelim = True``, eight header lines and then the samples::

    line 1  (blank)
    line 2  Predictions were generated on 26-Nov-2026 at 11:06:16 using IceImpact 0.3.0 (...)
    line 3  linked with <the solver>
    line 4  (blank)
    line 5  Description from the IceImpact input: <what was simulated>
    line 6  (blank)
    line 7  Time<TAB>structure.x<TAB>...          channel names, ``Time`` first
    line 8  (s)<TAB>(m)<TAB>...                   units in parentheses, ``(-)`` for none
    then    one line per sample: tab-separated, ``%.9E`` (10 significant digits)

What the readers rely on, and this writer keeps: the names on line 7 and the units on line 8
(openfast-io reads those lines by number, the others take the first line starting with
``Time`` as the names and the next as the units), no whitespace inside a name or a unit, tabs
between the fields (pCrunch splits on tabs), an ASCII header (pCrunch decodes it as ASCII) and no
header line other than line 7 starting with ``Time``.

The channels (:data:`OUT_CHANNELS`) are the FMU's outputs with the contract's units
(:mod:`iceimpact.contract`), sampled at the run's sample times; the per-interval ones
(``contact.impulse``, ``contact.force``) cover the interval up to their sample, 0 at ``t = 0``.

:func:`write_openfast` writes a run (``iceimpact simulate --format openfast``),
:func:`write_out` any channels; :func:`read_out` reads such a file back; :func:`case_file_name`
names the file of a load-case run (:func:`iceimpact.seasons.write_case_series` writes them).
"""

from __future__ import annotations

import time as _time
import unicodedata
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..contract import BY_NAME, VERSION
from .loads import contact_force, spring_force

#: The time channel, as OpenFAST names it.
TIME_CHANNEL = "Time"

#: The channels of :func:`write_openfast` after ``Time``: FMU output names (units from the
#: contract). ``structure.force`` is the spring force k x (the base shear; k_c x, the
#: quasi-static equivalent load at the contact point, with the modal structure),
#: ``contact.force`` the mean contact force over the sample interval, ``contact.count`` the
#: impacts up to the sample.
OUT_CHANNELS: tuple[str, ...] = (
    "structure.x", "structure.v", "ice.z", "ice.v", "contact.gap", "contact.penetration",
    "structure.force", "contact.force", "contact.impulse", "contact.count", "contact.active")

#: Digits after the point of the samples (``%.9E``: 10 significant digits; OpenFAST's default
#: ``OutFmt = "ES10.3E2"`` prints 4).
DIGITS = 9

#: Unit written for a channel without one (counts, flags), as OpenFAST does.
NO_UNIT = "-"


def channel_unit(name: str) -> str:
    """The unit of channel ``name`` as the header writes it (without the parentheses)."""
    if name == TIME_CHANNEL:
        return "s"
    unit = BY_NAME[name].unit
    return unit if unit not in ("", "1") else NO_UNIT


def run_channels(result: Any) -> dict[str, np.ndarray]:
    """``Time`` and :data:`OUT_CHANNELS` of a run (:class:`iceimpact.Result`), as float arrays over
    its samples."""
    t = np.asarray(result.t, dtype=float)
    impulse = np.asarray(result.impulse, dtype=float)
    impact_t = np.asarray(result.impacts["t"], dtype=float)
    values = {
        TIME_CHANNEL: t,
        "structure.x": result.x, "structure.v": result.v, "ice.z": result.z, "ice.v": result.w,
        "contact.gap": result.gap, "contact.penetration": result.penetration,
        "structure.force": spring_force(result.scene, result.x),
        "contact.force": contact_force(t, impulse),
        "contact.impulse": impulse,
        "contact.count": np.searchsorted(np.sort(impact_t), t, side="right"),
        "contact.active": result.sticking,
    }
    return {name: np.asarray(values[name], dtype=float)
            for name in (TIME_CHANNEL, *OUT_CHANNELS)}


def _ascii_line(text: str) -> str:
    """``text`` on one line of ASCII (pCrunch decodes the header as ASCII): accents dropped,
    other characters escaped, tabs and line breaks made spaces."""
    text = " ".join(str(text).split())
    # accents dropped (Woehler -> Wohler), anything else escaped (\xb5)
    text = "".join(c for c in unicodedata.normalize("NFKD", text)
                   if not unicodedata.combining(c))
    return text.encode("ascii", "backslashreplace").decode("ascii")


def header_lines(names: Sequence[str], units: Sequence[str], description: str = "",
                 generated: float | None = None, solver: str = "") -> list[str]:
    """The eight header lines of an OpenFAST text output (without line ends)."""
    if len(names) != len(units):
        raise ValueError(f"{len(names)} channel names but {len(units)} units")
    if not names or names[0] != TIME_CHANNEL:
        raise ValueError(f"the first channel must be {TIME_CHANNEL!r}")
    for label in (*names, *units):
        if not label or label != _ascii_line(label) or " " in label:
            raise ValueError(f"channel name or unit {label!r}: must be ASCII without whitespace")
    stamp = _time.localtime(_time.time() if generated is None else generated)
    when = _time.strftime("%d-%b-%Y at %H:%M:%S", stamp)
    description = _ascii_line(description)
    # no header line but the names may start with "Time": the readers look for it
    return ["",
            f"Predictions were generated on {when} using IceImpact {VERSION} (iceimpact)",
            _ascii_line(f"linked with {solver or 'the IceImpact core'}"),
            "",
            f"Description from the IceImpact input: {description}".rstrip(),
            "",
            "\t".join(names),
            "\t".join(f"({u})" for u in units)]


def write_out(path: str | Path, channels: Mapping[str, Any], units: Mapping[str, str] | None = None,
              description: str = "", generated: float | None = None, solver: str = "") -> Path:
    """Write ``channels`` (name -> 1-d array, ``Time`` first, all of one length) as an OpenFAST
    text output at ``path``; ``units`` by name (default :func:`channel_unit`). Returns the path."""
    path = Path(path)
    names = list(channels)
    columns = [np.asarray(channels[n], dtype=float).ravel() for n in names]
    if len({c.size for c in columns}) > 1:
        raise ValueError("channels of different lengths: "
                         + ", ".join(f"{n} {c.size}" for n, c in zip(names, columns, strict=True)))
    unit_of = units or {}
    header = header_lines(names, [unit_of.get(n) or channel_unit(n) for n in names],
                          description, generated, solver)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write("\n".join(header) + "\n")
        if columns and columns[0].size:
            np.savetxt(fh, np.column_stack(columns), fmt=f"%.{DIGITS}E", delimiter="\t")
    return path


def solver_text(scene: Any) -> str:
    """The solver of a scene in words, for line 3 of the header."""
    method = BY_NAME["solver.method"].choices.get(scene.solver_method, str(scene.solver_method))
    return f"the IceImpact core, {method} solver"


def write_openfast(path: str | Path, result: Any, description: str = "",
                   generated: float | None = None) -> Path:
    """Write a run (:class:`iceimpact.Result`) as an OpenFAST text output: ``Time`` and
    :data:`OUT_CHANNELS` at every sample (see the module docstring). ``description`` goes on
    line 5 (what was simulated); ``generated`` is the time stamp of line 2 (default: now)."""
    return write_out(path, run_channels(result), description=description, generated=generated,
                     solver=solver_text(result.scene))


def read_out(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, str], str]:
    """(channels, units, description) of an OpenFAST text output: the header up to the line that
    starts with ``Time`` (the names) and the next (the units), as pyDatView reads it; ValueError
    if the file is not one."""
    path = Path(path)
    with open(path, encoding="utf-8", errors="replace") as fh:
        header: list[str] = []
        for line in fh:
            if line.split()[:1] == [TIME_CHANNEL]:
                names = line.split()
                units = [u[1:-1] if u.startswith("(") and u.endswith(")") else u
                         for u in fh.readline().split()]
                break
            header.append(line.strip())
            if len(header) > 100:
                raise ValueError(f"{path}: no line of channel names starting with "
                                 f"{TIME_CHANNEL!r} in its first 100 lines")
        else:
            raise ValueError(f"{path}: no line of channel names starting with "
                             f"{TIME_CHANNEL!r}")
        try:
            data = np.loadtxt(fh, dtype=float, ndmin=2)
        except ValueError as exc:
            raise ValueError(f"{path}: a sample line is not {len(names)} numbers ({exc})") from None
    if data.size and data.shape[1] != len(names):
        raise ValueError(f"{path}: {data.shape[1]} values per line but {len(names)} channels")
    channels = {n: (data[:, i] if data.size else np.empty(0)) for i, n in enumerate(names)}
    description = next((h.partition(":")[2].strip() for h in header
                        if h.startswith("Description")), "")
    return channels, dict(zip(names, units, strict=False)), description


def case_file_name(index: int, name: str, repetition: int) -> str:
    """File name of a load case's run: ``case<index>_<name>_rep<k>.out``, the name reduced to
    letters, digits, ``-`` and ``_`` (``case01_fast-floe_rep0.out``)."""
    slug = "".join(c if c.isalnum() or c in "-_" else "-" for c in _ascii_line(name))
    slug = "-".join(filter(None, slug.split("-")))[:60] or "case"
    return f"case{index:02d}_{slug}_rep{repetition}.out"
