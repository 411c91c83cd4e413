"""IceImpact: the FMI 2.0 Co-Simulation slave (PythonFMU) around :mod:`iceimpact`.

FMI plumbing only, all of it shared with the project's other FMU
(:class:`iceimpact.fmi.slave_base.FmuSlave`): the variables and metadata come from the contract
table (:mod:`iceimpact.contract`), every call is passed to
:class:`iceimpact.fmi.adapter.FmuModel`, which holds the life-cycle rules, and the FMU state is
serialized by :mod:`iceimpact.fmi.state`. The model core is bundled under ``resources/`` by
``build_fmu.py``.
"""

from __future__ import annotations

from iceimpact import contract
from iceimpact.fmi.adapter import FmuModel
from iceimpact.fmi.pythonfmu_fixes import hold_module_dict
from iceimpact.fmi.slave_base import FmuSlave

hold_module_dict(globals())  # at each execution, should PythonFMU run this module itself


class IceImpact(FmuSlave):
    """Flow-driven repeated ice impacts on a flexible structure (FMI 2.0 Co-Simulation)."""

    CONTRACT = contract
    MODEL = FmuModel
