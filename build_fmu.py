"""Build dist/IceImpact.fmu and dist/ModalStructure.fmu (FMI 2.0 Co-Simulation) with PythonFMU,
dist/IceImpact3.fmu and dist/ModalStructure3.fmu (the same as FMI 3.0 Co-Simulation FMUs) and
dist/IceOnStructure.ssp (the two coupled).

    python build_fmu.py [--dest dist] [--fmu all|IceImpact|ModalStructure|IceImpact3|...]
                        [--standalone] [--variables-table]

``--standalone`` also writes ``<dest>/standalone/<FMU>.fmu``: the same FMU with its own CPython
runtime, numpy and scipy, for Linux x86_64 machines with no Python.

The build itself is the package ``fmu_build`` beside this file, one module per step (its
docstring lists them). This file is its entry point, and keeps the names that scripts and tests
call on it, whether they import it or load it by its path: ``build``, ``build_modal``,
``build_slave``, ``make_standalone``, ``fmi3_from_fmi2``, ``build_fmi3``, ``compile_loader``,
``python_version``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def build_package() -> ModuleType:
    """The package fmu_build of this file's folder: imported by name when that is the one the
    module path finds, else loaded from its folder under a private name (a script loads this file
    by its path, maybe of another checkout, with neither folder on the module path)."""
    folder = Path(__file__).resolve().parent / "fmu_build"
    found = importlib.util.find_spec("fmu_build")
    if found is not None and found.origin and Path(found.origin).resolve().parent == folder:
        return importlib.import_module("fmu_build")
    name = "_fmu_build_" + hashlib.sha256(str(folder).encode()).hexdigest()[:12]
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, folder / "__init__.py", submodule_search_locations=[str(folder)])
        package = importlib.util.module_from_spec(spec)
        sys.modules[name] = package  # before it runs: its modules import each other through it
        spec.loader.exec_module(package)
    return sys.modules[name]


_package = build_package()
build = _package.build
build_modal = _package.build_modal
build_slave = _package.build_slave
make_standalone = _package.make_standalone
fmi3_from_fmi2 = _package.fmi3_from_fmi2
build_fmi3 = _package.build_fmi3
compile_loader = _package.compile_loader
python_version = _package.python_version
main = _package.main

if __name__ == "__main__":
    sys.exit(main())
