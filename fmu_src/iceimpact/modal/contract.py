"""The FMI contract of ModalStructure.fmu: every variable, its unit, range, start value and meaning.

The one home of the structure FMU's interface: the slave (``fmu_src/ModalStructure.py``)
registers exactly these variables, :mod:`iceimpact.modal.fmu` validates the parameters against the
ranges here, ``build_fmu.py`` writes units, min/max, descriptions and the default experiment from
it, and docs/explanation/coupling.md lists it (:func:`markdown_table`).

FMI 2.0 has no arrays: the FMU has :data:`MAX_MODES` modes, ``mode1.*`` to ``mode5.*``, of which
the first ``modes`` are used (the others are ignored and not validated). The defaults are one mode
equal to IceImpact's built-in structure (m = 1600 kg, c = 200 N.s/m, k = 1e6 N/m, seen with
phi = 1); modes 2 to 5 have the same frequency, damping and mass but ``phi = 0``, so a mode switched
on without values of its own does not move the contact point.

The variables are :class:`iceimpact.contract.Variable` rows (for a mode parameter, ``field`` is
the :class:`~iceimpact.modal.Mode` field, or ``q0``/``v0``; the mode number is in the name), with
the causalities, variabilities, number format and table layout of :mod:`iceimpact.contract`. This
module imports nothing else from the package: it is a bottom layer.
"""

from __future__ import annotations

from .. import contract
from ..contract import (
    CONTINUOUS,
    FIXED,
    INPUT,
    OUTPUT,
    PARAMETER,
    DefaultExperiment,
    Variable,
)

VERSION = "0.1.0"

MODEL_IDENTIFIER = "ModalStructure"
AUTHOR = contract.AUTHOR
LICENSE = contract.LICENSE
DESCRIPTION = ("A linear structure given by up to 5 modes, seen at one contact point: contact "
               "force in, displacement, velocity and acceleration out; exact for a force held "
               "over each step")

MAX_MODES = contract.MAX_MODES

#: IceImpact's DefaultExperiment (400 s at 1 ms steps), for coupled runs.
DEFAULT_EXPERIMENT = DefaultExperiment()


def _mode_parameters(k: int) -> tuple[Variable, ...]:
    """Mode k's parameters: :func:`iceimpact.contract.mode_rows`, named ``mode<k>.<field>``."""
    return tuple(Variable(f"mode{k}.{field}", field, PARAMETER, float, unit,
                          f"mode {k}: {meaning}", start, **limits)
                 for field, unit, meaning, start, limits in contract.mode_rows(k))


MODES_PARAMETER = Variable(
    "modes", "modes", PARAMETER, int, "",
    f"number of modes used (mode1 to mode<modes>; 1 to {MAX_MODES})", 1,
    allowed=f"1 <= modes <= {MAX_MODES}", minimum=1, maximum=MAX_MODES)

#: Parameters, in the order of their value references (append new ones at the end).
PARAMETERS: tuple[Variable, ...] = (MODES_PARAMETER,) + tuple(
    v for k in range(1, MAX_MODES + 1) for v in _mode_parameters(k))

#: The input, held constant over each communication step (zero-order hold).
INPUTS: tuple[Variable, ...] = (
    Variable("force", "force", INPUT, float, "N",
             "contact force on the structure at the contact point, positive in the direction of x "
             "(IceImpact's coupling.force)", 0.0,
             variability=CONTINUOUS),
)
FORCE_INPUT = INPUTS[0]


def _mode_knowns(*fields: str) -> tuple[str, ...]:
    """``modes`` and the given parameters of every mode: each mode enters the initial outputs
    once ``modes`` includes it."""
    return (MODES_PARAMETER.name,) + tuple(f"mode{k}.{field}" for k in range(1, MAX_MODES + 1)
                                           for field in fields)


#: Outputs: the contact point at the end of the last communication step. x and v are stored by
#: fmi2DoStep; a is computed when read, from the modal state and the current force, whose factor
#: sum(phi^2 / m) is fixed (FMI dependenciesKind "fixed"). After initialization x = sum phi q0,
#: v = sum phi v0 over the modes used, a from every mode parameter and force.
OUTPUTS: tuple[Variable, ...] = (
    Variable("x", "x", OUTPUT, float, "m", "displacement of the contact point",
             variability=CONTINUOUS, allowed="", initial_depends_on=_mode_knowns("phi", "q0")),
    Variable("v", "v", OUTPUT, float, "m/s", "velocity of the contact point",
             variability=CONTINUOUS, allowed="", initial_depends_on=_mode_knowns("phi", "v0")),
    Variable("a", "a", OUTPUT, float, "m/s2", "acceleration of the contact point under the current "
             "value of force (at the end of a step: under the force of that step)",
             variability=CONTINUOUS, allowed="", depends_on={FORCE_INPUT.name: FIXED},
             initial_depends_on=tuple(p.name for p in PARAMETERS) + (FORCE_INPUT.name,)),
)

#: Every variable, in value-reference order per type as the slave registers them.
VARIABLES: tuple[Variable, ...] = PARAMETERS + INPUTS + OUTPUTS
BY_NAME: dict[str, Variable] = {v.name: v for v in VARIABLES}


def markdown_table() -> str:
    """The variables as the Markdown table of docs/explanation/coupling.md (``mode2.*`` to
    ``mode5.*``
    summarised in one row)."""
    return contract.markdown_table(VARIABLES, fold="mode", fold_note=(
        f"the same six parameters for modes 2 to {MAX_MODES}"))
