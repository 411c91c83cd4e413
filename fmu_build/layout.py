"""Where the build reads its sources from, and the names of the FMUs it makes.

Every module of :mod:`fmu_build` takes its paths and model identifiers from here, so that the
repository's layout is written once.
"""

from __future__ import annotations

from pathlib import Path

#: The repository: build_fmu.py, fmu_src/, fmu_native/, pyproject.toml.
ROOT = Path(__file__).resolve().parents[1]
#: The slaves (IceImpact.py, ModalStructure.py), the model core and the FMU's boot module.
FMU_SRC = ROOT / "fmu_src"
#: The model core every FMU carries under resources/.
PACKAGE_NAME = "iceimpact"
#: The boot module every FMU carries as resources/iceimpact_fmu/boot.py.
BOOT_MODULE = FMU_SRC / "iceimpact_fmu_boot.py"
#: IceImpact.fmu: its model identifier, and its slave's module and class name.
SLAVE_NAME = "IceImpact"
#: ModalStructure.fmu, the linear structure given by its modes (docs/explanation/coupling.md).
MODAL_SLAVE_NAME = "ModalStructure"
#: The layout rules of the variables table, shared by the site and each FMU's own page.
VARIABLES_CSS = ROOT / "docs" / "stylesheets" / "variables.css"
#: The default output folder of the command line.
DIST = ROOT / "dist"
