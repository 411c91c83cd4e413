"""The build of the FMUs: ``python build_fmu.py`` (:mod:`fmu_build.cli`) is its command line.

It writes dist/IceImpact.fmu and dist/ModalStructure.fmu (FMI 2.0 Co-Simulation, built with
PythonFMU), dist/IceImpact3.fmu and dist/ModalStructure3.fmu (the same as FMI 3.0 Co-Simulation
FMUs), dist/IceOnStructure.ssp (the two coupled), and with ``--standalone``
dist/standalone/<FMU>.fmu, each with its own CPython runtime, numpy and scipy. One module per
step:

- :mod:`fmu_build.layout`: the repository's folders and the FMUs' names;
- :mod:`fmu_build.fmi2`: an FMI 2.0 FMU of a slave, built with PythonFMU (:func:`build`,
  :func:`build_modal`, :func:`build_slave`);
- :mod:`fmu_build.model_description`: its modelDescription.xml completed from the contract table
  (units, ranges, start values, model structure, default experiment);
- :mod:`fmu_build.native`: the C loader (fmu_native/) compiled for a Python
  (:func:`compile_loader`);
- :mod:`fmu_build.native_hosts`: the FMU repackaged so that any host, a native one with an empty
  environment too, loads it and runs its own code;
- :mod:`fmu_build.standalone`: the FMU with its own Python runtime (:func:`make_standalone`),
  with :mod:`fmu_build.probe`, the program that measures what the slave imports;
- :mod:`fmu_build.fmi3`: the FMI 3.0 FMU made of an FMI 2.0 one (:func:`fmi3_from_fmi2`,
  :func:`build_fmi3`);
- :mod:`fmu_build.documentation`: the page each FMU carries, documentation/index.html, from
  its contract table;
- :mod:`fmu_build.compatibility`: what the FMUs run on and in, written once for that page and
  for the compatibility box of README.md and docs/index.md;
- :mod:`fmu_build.cli`: the command line, and the system file written beside the FMUs.

It is build tooling, not part of the model: the FMUs carry the ``iceimpact`` package and the
slaves from fmu_src/, never this package. It is imported from the repository (its folder on the
module path, as ``python build_fmu.py`` has it), or by build_fmu.py from beside it when a script
loads that file by its path.
"""

from .cli import main
from .documentation import documentation_page
from .fmi2 import build, build_modal, build_slave, requirements
from .fmi3 import build_fmi3, fmi3_from_fmi2, fmi3_model_description
from .layout import FMU_SRC, MODAL_SLAVE_NAME, ROOT, SLAVE_NAME
from .model_description import base_units, complete_model_description
from .native import NativeBuildError, compile_loader, libpython, python_version
from .native_hosts import package_for_native_hosts
from .standalone import STANDALONE_DIR, imported_modules, make_standalone

__all__ = [
    "FMU_SRC", "MODAL_SLAVE_NAME", "ROOT", "SLAVE_NAME", "STANDALONE_DIR", "NativeBuildError",
    "base_units", "build", "build_fmi3", "build_modal", "build_slave", "compile_loader",
    "complete_model_description", "documentation_page", "fmi3_from_fmi2",
    "fmi3_model_description",
    "imported_modules", "libpython", "main", "make_standalone", "package_for_native_hosts",
    "python_version", "requirements",
]
