"""ModalStructure.fmu's side of the package: a linear structure given by its modes.

``structure.py`` is the modal core (no FMI), ``contract.py`` its FMI variables (rows of
:class:`iceimpact.contract.Variable`), ``fmu.py`` its model on the shared FMI life cycle and its
state record. docs/explanation/coupling.md tells how it is coupled with IceImpact.fmu.
"""

from .structure import ModalStructure, Mode

__all__ = ["ModalStructure", "Mode"]
