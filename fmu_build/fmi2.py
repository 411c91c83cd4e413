"""The FMI 2.0 Co-Simulation FMUs, IceImpact.fmu and ModalStructure.fmu, built with PythonFMU.

Each FMU carries its slave (``fmu_src/<id>.py``), the model core (the ``iceimpact`` package) and a
requirements.txt (numpy, scipy) under ``resources/``; it runs wherever a Python with numpy and
scipy is available, without ``iceimpact`` being installed. After PythonFMU's build, its
modelDescription.xml is completed from the slave's contract table
(:mod:`fmu_build.model_description`) and the FMU is repackaged for native hosts
(:mod:`fmu_build.native_hosts`).

ModalStructure.fmu is the structure FMU of docs/explanation/coupling.md: a linear structure given
by its modes (``iceimpact.modal``), its variables in the contract table
``iceimpact.modal.contract``. It is built like IceImpact.fmu (the same bundle, requirements and
native-host packaging), from ``fmu_src/ModalStructure.py``.
"""

from __future__ import annotations

import importlib
import re
import sys
import tempfile
from pathlib import Path

from .documentation import add_to_fmu
from .layout import DIST, FMU_SRC, MODAL_SLAVE_NAME, PACKAGE_NAME, ROOT, SLAVE_NAME
from .model_description import rewrite_model_description
from .native_hosts import package_for_native_hosts

#: What the FMU needs at run time; the versions come from pyproject.toml. (The package's other
#: dependencies, such as rainflow for design loads, serve studies, not the FMU.)
FMU_RUNTIME_PACKAGES = ("numpy", "scipy")


def requirements() -> str:
    """The run-time requirements of the FMU: numpy and scipy, as pyproject.toml pins them."""
    import tomllib

    with open(ROOT / "pyproject.toml", "rb") as fh:
        deps = tomllib.load(fh)["project"]["dependencies"]
    wanted = [d for d in deps if re.split(r"[<>=!~;\[ ]", d, maxsplit=1)[0].strip().lower()
              in FMU_RUNTIME_PACKAGES]
    return "".join(f"{dep}\n" for dep in wanted)


def check_builder() -> None:
    """Refuse to build with a PythonFMU that has no FMI binaries to put in the FMU: the slim copy
    inside an FMU's resources/ (no builder's binaries), which PythonFMU puts first on
    ``sys.path`` of a Python host that ran the FMU in its own process (FMPy). The FMU built would
    lack ``binaries/``; the message says where the copy lies and what to do."""
    import pythonfmu

    folder = Path(pythonfmu.__file__).resolve().parent
    binaries = folder / "resources" / "binaries"
    if not binaries.is_dir() or not any(f.suffix in (".so", ".dll", ".dylib")
                                        for f in binaries.rglob("*")):
        raise RuntimeError(
            f"pythonfmu was imported from {folder}, which has no FMI binaries ({binaries}): an "
            "FMU's resources/ folder is first on sys.path (an FMU run in this process puts it "
            "there). Build the FMU in a fresh process, or import pythonfmu.builder before "
            "running an FMU.")


def build(dest: str | Path = DIST, source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/IceImpact.fmu`` from ``<source_dir>/IceImpact.py`` and its package."""
    return build_slave(SLAVE_NAME, "iceimpact.contract", dest, source_dir)


def build_modal(dest: str | Path = DIST, source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/ModalStructure.fmu`` from ``<source_dir>/ModalStructure.py`` and the
    ``iceimpact`` package (its contract: :mod:`iceimpact.modal.contract`)."""
    return build_slave(MODAL_SLAVE_NAME, "iceimpact.modal.contract", dest, source_dir)


def build_slave(slave_name: str, contract_module: str, dest: str | Path = DIST,
                source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/<slave_name>.fmu`` from ``<source_dir>/<slave_name>.py`` and the
    ``iceimpact`` package; ``contract_module`` names its contract table (imported from
    ``source_dir``), which completes modelDescription.xml."""
    source_dir = Path(source_dir).resolve()
    dest = Path(dest).resolve()
    dest.mkdir(parents=True, exist_ok=True)
    # the contract that completes the description is the one of the sources bundled, installed
    # or not
    if str(source_dir) not in sys.path:
        sys.path.insert(0, str(source_dir))
    check_builder()
    from pythonfmu import FmuBuilder

    contract = importlib.import_module(contract_module)
    with tempfile.TemporaryDirectory(prefix=f"{slave_name.lower()}_fmu_") as tmp:
        req = Path(tmp) / "requirements.txt"
        req.write_text(requirements())
        fmu = Path(FmuBuilder.build_FMU(
            source_dir / f"{slave_name}.py",
            dest=dest,
            project_files=[source_dir / PACKAGE_NAME, req],
            canGetAndSetFMUstate=True,
            canSerializeFMUstate=True,
        ))
    rewrite_model_description(fmu, contract)
    package_for_native_hosts(fmu, slave_name)
    add_to_fmu(fmu, slave_name, "2.0", standalone=False)  # documentation/index.html
    return fmu
