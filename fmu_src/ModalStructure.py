"""ModalStructure: the FMI 2.0 Co-Simulation slave (PythonFMU) of a structure given by its modes.

FMI plumbing only, all of it shared with IceImpact.fmu
(:class:`iceimpact.fmi.slave_base.FmuSlave`): the variables and metadata come from the contract
table (:mod:`iceimpact.modal.contract`), every call is passed to
:class:`iceimpact.modal.fmu.ModalFmuModel`, which holds the life-cycle rules and the state
record, and the physics is :class:`iceimpact.modal.ModalStructure`. ``build_fmu.py`` bundles the
``iceimpact`` package under ``resources/``.
"""

from __future__ import annotations

from iceimpact.fmi.pythonfmu_fixes import hold_module_dict
from iceimpact.fmi.slave_base import FmuSlave
from iceimpact.modal import contract as modal_contract
from iceimpact.modal.fmu import ModalFmuModel

hold_module_dict(globals())  # runs at each re-execution of this module by PythonFMU's loader


class ModalStructure(FmuSlave):
    """A linear structure given by up to 5 modes, seen at one contact point."""

    CONTRACT = modal_contract
    MODEL = ModalFmuModel
