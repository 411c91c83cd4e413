"""A PythonFMU-built FMU repackaged for any FMI host, a native one with an empty environment too.

PythonFMU's binaries/linux64/<id>.so does not link libpython, and it runs whatever module named
IceImpact / iceimpact the host process already has. The FMU is repackaged so that it loads in any
FMI host with an empty environment and always runs its own code:

    binaries/linux64/IceImpact.so            our loader (fmu_native/loader.c, compiled by
                                             :mod:`fmu_build.native`)
    binaries/linux64/pythonfmu/IceImpact.so  PythonFMU's library, loaded by the loader
    resources/_iceimpact_<id>_fmu.py         entry module that PythonFMU imports (generated, named
                                             in resources/slavemodule.txt)
    resources/iceimpact_fmu/IceImpact.py     the slave, loaded under a private name
    resources/iceimpact_fmu/boot.py          fmu_src/iceimpact_fmu_boot.py
    resources/iceimpact_fmu/python.json      the build's Python: version, libpython, site folders

See docs/how-to/hand-over-the-fmu.md and docs/explanation/fmu-loader.md.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import re
import sys
import sysconfig
import tempfile
import warnings
import zipfile
from pathlib import Path

from .layout import BOOT_MODULE, PACKAGE_NAME, SLAVE_NAME
from .native import (
    NATIVE_PLATFORM,
    builds_native_loader,
    compile_loader,
    libpython,
    python_version,
)

ENTRY_MODULE = '''"""{slave}.fmu: the module PythonFMU imports (written by build_fmu.py).

resources/slavemodule.txt names this module, so PythonFMU imports it under this private name and
never picks up a module the host imported. PythonFMU 0.7.0 also executes this source again at
every fmi2Instantiate to find the slave class, and drops one reference to the module's dictionary
each time: so the file stays small (nothing is defined again per instance), gives the reference
back first (a bare increment of the count: a reference kept in a container would be released
again when the container is, and free the dictionary at interpreter shutdown), and takes the class
from iceimpact_fmu/boot.py, which loads the slave and the model core once, under private names.
"""
import ctypes as _ctypes

_ctypes.pythonapi.Py_IncRef(_ctypes.py_object(globals()))
import importlib.util as _util  # noqa: E402
import os as _os  # noqa: E402
import sys as _sys  # noqa: E402

_BOOT = "_iceimpact_{build_id}_boot"
if _BOOT not in _sys.modules:
    _spec = _util.spec_from_file_location(
        _BOOT, _os.path.join(_os.path.dirname(__file__), "iceimpact_fmu", "boot.py"))
    _sys.modules[_BOOT] = _util.module_from_spec(_spec)
    _spec.loader.exec_module(_sys.modules[_BOOT])
{slave} = _sys.modules[_BOOT].load_slave("{build_id}", "{slave}")
'''


def python_environment(requirement_lines: list[str], library: Path | None) -> dict:
    """What resources/iceimpact_fmu/python.json records of the building Python."""
    folders = [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]
    for line in requirement_lines:
        name = re.split(r"[<>=!~;\[ ]", line.strip(), maxsplit=1)[0]
        spec = importlib.util.find_spec(name) if name else None
        if spec is not None and spec.submodule_search_locations:
            folders.append(str(Path(next(iter(spec.submodule_search_locations))).parent))
    return {
        "python": python_version(),
        "prefix": sys.base_prefix,
        "libpython": str(library) if library else None,
        "site": list(dict.fromkeys(str(Path(f).resolve()) for f in folders)),
        "requirements": [line.strip() for line in requirement_lines if line.strip()],
    }


def build_id(files: dict[str, bytes]) -> str:
    """Digest of the bundled Python sources: the suffix of the private module names."""
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + files[name] + b"\0")
    return digest.hexdigest()[:12]


def entry_module_name(ident: str) -> str:
    """The private name PythonFMU imports the entry module of the build ``ident`` under."""
    return f"_iceimpact_{ident}_fmu"


def package_for_native_hosts(fmu: Path, slave_name: str = SLAVE_NAME) -> None:
    """Rearrange a PythonFMU-built FMU as described above (Linux x86_64 builds only).

    ``slave_name`` is the model identifier, the slave's module and class name (``IceImpact``
    above; ``ModalStructure`` for :func:`fmu_build.fmi2.build_modal`).
    """
    if not builds_native_loader():
        warnings.warn("the native loader is built on Linux x86_64 only: this FMU needs a Python "
                      "host, or LD_PRELOAD of libpython in native hosts", stacklevel=2)
        return
    with zipfile.ZipFile(fmu) as src:
        entries = {info.filename: src.read(info) for info in src.infolist()}
    slave = entries.pop(f"resources/{slave_name}.py")
    pythonfmu_library = entries.pop(f"binaries/{NATIVE_PLATFORM}/{slave_name}.so")
    library_path = f"pythonfmu/{slave_name}.so"  # relative to binaries/linux64
    ours = {f"resources/iceimpact_fmu/{slave_name}.py": slave,
            "resources/iceimpact_fmu/boot.py": BOOT_MODULE.read_bytes()}
    core = {name: data for name, data in entries.items()
            if name.startswith(f"resources/{PACKAGE_NAME}/")}
    ident = build_id({**ours, **core})
    requirement_lines = entries["resources/requirements.txt"].decode().splitlines()
    library, soname = libpython()
    environment = python_environment(requirement_lines, library)
    environment["model_identifier"] = slave_name  # boot.py names the FMU in its messages
    ours["resources/iceimpact_fmu/python.json"] = (
        json.dumps(environment, indent=2) + "\n").encode()
    entry = entry_module_name(ident)
    ours[f"resources/{entry}.py"] = ENTRY_MODULE.format(build_id=ident,
                                                        slave=slave_name).encode()
    ours["resources/slavemodule.txt"] = entry.encode()
    ours[f"binaries/{NATIVE_PLATFORM}/{library_path}"] = pythonfmu_library
    with tempfile.TemporaryDirectory(prefix="iceimpact_loader_") as tmp:
        loader = compile_loader(Path(tmp) / f"{slave_name}.so", library, soname, library_path)
        ours[f"binaries/{NATIVE_PLATFORM}/{slave_name}.so"] = loader.read_bytes()
    tmp_fmu = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED) as dst:
        for name, data in {**entries, **ours}.items():
            dst.writestr(name, data)
    tmp_fmu.replace(fmu)

