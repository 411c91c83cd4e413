"""ModalStructure3: the slave of the FMI 3.0 Co-Simulation FMU, ModalStructure3.fmu.

The same slave as ModalStructure.fmu's (``fmu_src/ModalStructure.py``): the same contract, model
and state, built into an FMU with the FMI 3.0 layer (``fmu_native/fmi3.c``). Its steps never
return early (a linear structure has no events); it takes any step size, so that a master can
step it to an impact time IceImpact3.fmu returned at.
"""

from __future__ import annotations

from iceimpact.fmi.pythonfmu_fixes import hold_module_dict
from iceimpact.fmi.slave_base import FmuSlave
from iceimpact.modal import contract as modal_contract
from iceimpact.modal.fmu import ModalFmuModel

hold_module_dict(globals())  # runs at each re-execution of this module by PythonFMU's loader


class ModalStructure3(FmuSlave):
    """A linear structure given by up to 5 modes, seen at one contact point (FMI 3.0)."""

    CONTRACT = modal_contract
    MODEL = ModalFmuModel
    FMI_VERSION = 3
