"""IceImpact3: the slave of the FMI 3.0 Co-Simulation FMU, IceImpact3.fmu.

The same slave as IceImpact.fmu's (``fmu_src/IceImpact.py``): the same contract, model and state.
``FMI_VERSION = 3`` only opens the two values through which the FMU's FMI 3.0 layer
(``fmu_native/fmi3.c``) asks for steps that return at impacts and reads where a step returned
(:data:`iceimpact.fmi.slave_base.FMI3_CHANNEL`).
"""

from __future__ import annotations

from iceimpact import contract
from iceimpact.fmi.adapter import FmuModel
from iceimpact.fmi.pythonfmu_fixes import hold_module_dict
from iceimpact.fmi.slave_base import FmuSlave

hold_module_dict(globals())  # at each execution, should PythonFMU run this module itself


class IceImpact3(FmuSlave):
    """Flow-driven repeated ice impacts on a flexible structure (FMI 3.0 Co-Simulation)."""

    CONTRACT = contract
    MODEL = FmuModel
    FMI_VERSION = 3
