"""Build dist/IceImpact.fmu and dist/ModalStructure.fmu (FMI 2.0 Co-Simulation) with PythonFMU,
and dist/IceImpact3.fmu and dist/ModalStructure3.fmu, the same as FMI 3.0 Co-Simulation FMUs.

    python build_fmu.py [--dest dist] [--fmu all|IceImpact|ModalStructure|IceImpact3|...]
                        [--standalone]

The FMI 3.0 FMUs are made from FMI 2.0 builds of the same slaves (:func:`build_fmi3`, section
"FMI 3.0" below).

``--standalone`` also writes ``<dest>/standalone/<FMU>.fmu``: the same FMU with its own CPython
runtime, numpy and scipy, for Linux x86_64 machines with no Python (:func:`make_standalone`).

ModalStructure.fmu, a linear structure given by its modes to couple IceImpact.fmu with (see
docs/explanation/coupling.md), is built by :func:`build_modal` the same way, from
``fmu_src/ModalStructure.py`` and its contract table ``iceimpact.modal.contract``. The rest of this
text is about IceImpact.fmu.

The FMU carries the slave (fmu_src/IceImpact.py), the model core (the ``iceimpact`` package) and
a requirements.txt (numpy, scipy) under ``resources/``; it runs wherever a Python with numpy and
scipy is available, without ``iceimpact`` being installed.

PythonFMU writes no units, ranges or initial unknowns, so modelDescription.xml is completed here:
UnitDefinitions, the unit of every Real, min/max, ModelStructure/InitialUnknowns and the
DefaultExperiment. Units, descriptions, ranges and the default experiment come from the contract
table ``iceimpact.contract``, never from a second table.

For hosts that are not Python processes (a C master, the ECOS command line, libcosim) the FMU is
then repackaged (:func:`package_for_native_hosts`): a small loader compiled here from
``fmu_native/loader.c`` becomes ``binaries/linux64/IceImpact.so`` in front of PythonFMU's library,
and the Python environment of the build is recorded under ``resources/iceimpact_fmu/``. See
docs/how-to/hand-over-the-fmu.md and docs/explanation/fmu-loader.md.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import importlib.util
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import warnings
import zipfile
from pathlib import Path
from types import ModuleType
from xml.dom import minidom
from xml.etree import ElementTree as ET

ROOT = Path(__file__).resolve().parent
FMU_SRC = ROOT / "fmu_src"
SLAVE_NAME = "IceImpact"
PACKAGE_NAME = "iceimpact"
BOOT_MODULE = FMU_SRC / "iceimpact_fmu_boot.py"
LOADER_SOURCE = ROOT / "fmu_native" / "loader.c"
FMI3_SOURCE = ROOT / "fmu_native" / "fmi3.c"
FMI3_HEADERS = ROOT / "fmu_native" / "fmi3"  # the FMI 3.0 standard's headers (2-Clause BSD)

# SI base-unit exponents of the symbols that unit strings are written with ("N.s/m", "kg/m3").
_SYMBOLS = {
    "kg": {"kg": 1},
    "m": {"m": 1},
    "s": {"s": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "Hz": {"s": -1},
}


def base_units(unit: str) -> dict[str, int]:
    """SI base-unit exponents of a unit string such as ``"N.s/m"``, ``"kg/m3"`` or ``"1"``."""
    exponents: dict[str, int] = {}
    if unit == "1":
        return exponents
    numerator, _, denominator = unit.partition("/")
    for part, sign in ((numerator, 1), (denominator, -1)):
        for factor in filter(None, part.split(".")):
            match = re.fullmatch(r"([A-Za-z]+)(-?\d*)", factor)
            if match is None or match.group(1) not in _SYMBOLS:
                raise ValueError(f"cannot decompose unit {unit!r} (factor {factor!r})")
            power = int(match.group(2) or 1) * sign
            for base, exp in _SYMBOLS[match.group(1)].items():
                exponents[base] = exponents.get(base, 0) + power * exp
    return {base: exp for base, exp in exponents.items() if exp != 0}


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


def complete_model_description(xml: bytes, contract: ModuleType) -> bytes:
    """Add units, ranges, full-precision start values, descriptions, the model structure (outputs
    and initial unknowns with their dependencies) and the default experiment to PythonFMU's XML,
    all read from a contract table module (:mod:`iceimpact.contract`,
    :mod:`iceimpact.modal.contract`: ``BY_NAME``, name -> variable; ``DEFAULT_EXPERIMENT``)."""
    from iceimpact.contract import DEPENDENT, number_text

    root = ET.fromstring(xml)
    used_units: list[str] = []
    outputs: list[int] = []
    model_variables = root.find("ModelVariables")
    for index, var in enumerate(model_variables.findall("ScalarVariable"), start=1):
        name = var.get("name")
        spec = contract.BY_NAME[name]
        if not var.get("description"):
            var.set("description", spec.description)
        type_node = var[0]
        if type_node.tag == "Real":
            if not spec.unit:
                raise ValueError(f"no unit for the Real variable {name!r}")
            type_node.set("unit", spec.unit)
            if spec.unit not in used_units:
                used_units.append(spec.unit)
        if type_node.tag in ("Integer", "Boolean") and var.get("causality") not in (
                "parameter", "calculatedParameter"):
            var.set("variability", "discrete")
        if type_node.get("start") is not None and spec.start is not None:
            # PythonFMU writes 16 significant digits; the start value is the contract's double
            type_node.set("start", number_text(spec.start))
        if type_node.tag in ("Real", "Integer"):
            if spec.minimum is not None:
                type_node.set("min", number_text(spec.minimum))
            if spec.maximum is not None:
                type_node.set("max", number_text(spec.maximum))
        if var.get("causality") == "output":
            outputs.append(index)
            if var.get("initial") is None:
                var.set("initial", "calculated")

    # UnitDefinitions: after <CoSimulation>, before <LogCategories> (fmiModelDescription schema).
    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    unit_defs = ET.Element("UnitDefinitions")
    for unit in sorted(used_units):
        node = ET.SubElement(unit_defs, "Unit", name=unit)
        ET.SubElement(node, "BaseUnit", {k: str(v) for k, v in base_units(unit).items()})
    root.insert(list(root).index(root.find("CoSimulation")) + 1, unit_defs)

    experiment = contract.DEFAULT_EXPERIMENT
    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    root.insert(list(root).index(model_variables), ET.Element("DefaultExperiment", {
        "startTime": number_text(experiment.start_time),
        "stopTime": number_text(experiment.stop_time),
        "stepSize": number_text(experiment.step_size)}))

    # ModelStructure: every output with the knowns it depends on, as the contract declares them
    # (within a step: inputs; at initialization: inputs and parameters, FMI 2.0 section 2.2.8).
    variables = model_variables.findall("ScalarVariable")
    inputs = _indices(variables, lambda var: var.get("causality") == "input")
    initial_knowns = _indices(variables, lambda var: var.get("causality") == "input" or (
        var.get("causality") == "parameter" and var.get("initial", "exact") == "exact"))
    structure = root.find("ModelStructure")
    for old in structure.findall("Outputs") + structure.findall("InitialUnknowns"):
        structure.remove(old)
    listed = ET.Element("Outputs")
    initial = ET.Element("InitialUnknowns")
    for index in outputs:
        spec = contract.BY_NAME[variables[index - 1].get("name")]
        _declare_dependencies(ET.SubElement(listed, "Unknown", index=str(index)),
                              spec.depends_on, inputs, _OUTPUT_KINDS, f"{spec.name}: Outputs")
        _declare_dependencies(ET.SubElement(initial, "Unknown", index=str(index)),
                              dict.fromkeys(spec.initial_depends_on, DEPENDENT),
                              initial_knowns, _INITIAL_KINDS, f"{spec.name}: InitialUnknowns")
    structure.insert(0, listed)  # Outputs, (Derivatives,) InitialUnknowns: the schema's order
    structure.append(initial)

    text = ET.tostring(root, encoding="unicode")
    pretty = minidom.parseString(text).toprettyxml(indent="  ", encoding="UTF-8")
    return b"\n".join(line for line in pretty.splitlines() if line.strip()) + b"\n"


# dependenciesKind values FMI 2.0 allows: for Outputs all five, for InitialUnknowns only these two
_OUTPUT_KINDS = ("dependent", "constant", "fixed", "tunable", "discrete")
_INITIAL_KINDS = ("dependent", "constant")


def _indices(variables: list[ET.Element], wanted) -> dict[str, int]:
    """Name -> ScalarVariable index (from 1) of the variables ``wanted(variable)`` accepts."""
    return {var.get("name"): index for index, var in enumerate(variables, start=1)
            if wanted(var)}


def _declare_dependencies(unknown: ET.Element, kinds: dict[str, str], knowns: dict[str, int],
                          allowed_kinds: tuple[str, ...], where: str) -> None:
    """Set ``dependencies`` (indices, smallest first) and ``dependenciesKind`` of a ModelStructure
    ``Unknown`` from ``{known name: kind}``; ``knowns`` are the names it may list."""
    for name, kind in kinds.items():
        if name not in knowns:
            raise ValueError(f"{where}: {name!r} is not a known here ({', '.join(knowns)})")
        if kind not in allowed_kinds:
            raise ValueError(f"{where}: dependenciesKind {kind!r} of {name!r} is not one of "
                             f"{', '.join(allowed_kinds)}")
    pairs = sorted((knowns[name], kind) for name, kind in kinds.items())
    # both, even empty: no dependencies would mean "depends on every known", and FMPy's validator
    # wants both attributes or neither
    unknown.set("dependencies", " ".join(str(index) for index, _ in pairs))
    unknown.set("dependenciesKind", " ".join(kind for _, kind in pairs))


def _rewrite_model_description(fmu: Path, contract: ModuleType) -> None:
    with zipfile.ZipFile(fmu) as src:
        entries = [(info, src.read(info)) for info in src.infolist()]
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for info, data in entries:
            if info.filename == "modelDescription.xml":
                data = complete_model_description(data, contract)
            dst.writestr(info.filename, data, compress_type=zipfile.ZIP_DEFLATED)
    tmp.replace(fmu)


def build(dest: str | Path = ROOT / "dist", source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/IceImpact.fmu`` from ``<source_dir>/IceImpact.py`` and its package."""
    return build_slave(SLAVE_NAME, "iceimpact.contract", dest, source_dir)


def build_slave(slave_name: str, contract_module: str, dest: str | Path = ROOT / "dist",
                source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/<slave_name>.fmu`` from ``<source_dir>/<slave_name>.py`` and the
    ``iceimpact`` package; ``contract_module`` names its contract table (imported from
    ``source_dir``), which completes modelDescription.xml."""
    source_dir = Path(source_dir).resolve()
    dest = Path(dest).resolve()
    dest.mkdir(parents=True, exist_ok=True)
    if str(source_dir) not in sys.path:
        sys.path.insert(0, str(source_dir))
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
    _rewrite_model_description(fmu, contract)
    package_for_native_hosts(fmu, slave_name)
    return fmu


# Native hosts -----------------------------------------------------------------------------------
# PythonFMU's binaries/linux64/IceImpact.so does not link libpython, and it runs whatever module
# named IceImpact / iceimpact the host process already has. The FMU is repackaged so that it loads
# in any FMI host with an empty environment and always runs its own code:
#
#   binaries/linux64/IceImpact.so            our loader (fmu_native/loader.c, compiled here)
#   binaries/linux64/pythonfmu/IceImpact.so  PythonFMU's library, loaded by the loader
#   resources/_iceimpact_<id>_fmu.py         entry module that PythonFMU imports (generated, named
#                                            in resources/slavemodule.txt)
#   resources/iceimpact_fmu/IceImpact.py     the slave, loaded under a private name
#   resources/iceimpact_fmu/boot.py          fmu_src/iceimpact_fmu_boot.py
#   resources/iceimpact_fmu/python.json      the build's Python: version, libpython, site folders

NATIVE_PLATFORM = "linux64"
PYTHONFMU_LIBRARY = "pythonfmu/IceImpact.so"  # relative to binaries/linux64 (loader.c knows it)

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


class NativeBuildError(RuntimeError):
    """The native loader cannot be built on this machine (the message says what is missing)."""


def python_version() -> str:
    return "{}.{}".format(*sys.version_info[:2])


#: The Pythons a native host may run the default FMU with (its loader looks for their shared
#: libraries, the build's first). PythonFMU's library uses Python's stable ABI only, so it runs
#: in any of them; these are the versions tested (tests/test_native_hosts.py).
PYTHON_VERSIONS = ("3.11", "3.12", "3.13")


def python_versions() -> tuple[str, ...]:
    """:data:`PYTHON_VERSIONS`, the building Python's version first."""
    return (python_version(), *(v for v in PYTHON_VERSIONS if v != python_version()))


def libpython() -> tuple[Path | None, str]:
    """The shared libpython of the building Python (None if it has none) and its soname.

    Warns when there is none, or when the Python was relocated after it was built (an embedded
    interpreter started from the library then needs PYTHONHOME).
    """
    version = python_version()
    soname = sysconfig.get_config_var("INSTSONAME") or f"libpython{version}.so.1.0"
    if not soname.startswith("libpython") or ".so" not in soname:
        soname = f"libpython{version}.so.1.0"
    path = None
    if sysconfig.get_config_var("Py_ENABLE_SHARED"):
        candidate = Path(sysconfig.get_config_var("LIBDIR") or "") / soname
        path = candidate if candidate.exists() else None
    if path is None:
        warnings.warn(
            f"the Python building the FMU ({sys.base_prefix}) has no shared {soname} (it was built "
            "without --enable-shared): the FMU runs in Python hosts (FMPy, ecospy), but a native "
            f"host needs {soname} of a Python {version} installed on the library search path "
            f"(Debian/Ubuntu: apt-get install libpython{version}) or given with LD_PRELOAD",
            stacklevel=2)
    configured = sysconfig.get_config_var("prefix")
    if configured and Path(configured).resolve() != Path(sys.base_prefix).resolve():
        warnings.warn(
            f"this Python was built for {configured} and runs from {sys.base_prefix}: a native "
            f"host that starts it from {soname} needs PYTHONHOME={sys.base_prefix}",
            stacklevel=2)
    return path, soname


def python_environment(requirement_lines: list[str], library: Path | None) -> dict:
    """What resources/iceimpact_fmu/python.json records of the building Python."""
    import importlib.util

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


def compile_loader(dest: Path, library: Path | None, soname: str,
                   pythonfmu_library: str = PYTHONFMU_LIBRARY, *,
                   bundled_python: bool = False,
                   versions: tuple[str, ...] | None = None,
                   source: Path = LOADER_SOURCE,
                   extra_defines: dict[str, int] | None = None,
                   model_identifier: str | None = None) -> Path:
    """Compile fmu_native/loader.c into ``dest`` (a .so) for the libpython found by libpython();
    ``pythonfmu_library`` is where it finds PythonFMU's library, relative to binaries/linux64.
    In a native host the loader also looks for ``libpython<version>.so.1.0`` of the other
    ``versions`` (default :func:`python_versions`). With ``bundled_python`` the loader starts
    the runtime of a standalone FMU (:func:`make_standalone`) in a process without Python; that
    needs the build's Python.h. ``source`` is loader.c, or fmi3.c (the FMI 3.0 library, which
    includes it), with ``extra_defines`` (name -> integer); ``model_identifier`` names the FMU
    in the library's messages (default: PythonFMU's library's name)."""
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if compiler is None:
        raise NativeBuildError(
            "building IceImpact.fmu needs a C compiler for its loader (fmu_native/loader.c): "
            "none found (cc, gcc, $CC); install one (Debian/Ubuntu: apt-get install gcc, as "
            "scripts/system-deps.sh does)")
    defines = {
        "LIBPYTHON_PATH": str(library) if library else "",
        "LIBPYTHON_SONAME": soname,
        "PYTHON_VERSION": python_version(),
        "PYTHON_VERSIONS": " ".join(python_versions() if versions is None else versions),
        "PYTHONFMU_LIBRARY": pythonfmu_library,
        "MODEL_IDENTIFIER": model_identifier or Path(pythonfmu_library).stem,
    }
    flags = []
    if bundled_python:
        include = sysconfig.get_paths()["include"]
        if not (Path(include) / "Python.h").exists():
            raise NativeBuildError(
                f"the standalone FMU's loader needs Python.h of this Python ({include}): install "
                f"the Python headers (Debian/Ubuntu: apt-get install python{python_version()}-dev)")
        flags = ["-DBUNDLED_PYTHON", f"-I{include}"]
    command = [compiler, "-shared", "-fPIC", "-O2", "-std=c11", "-Wall", "-Wextra", "-Werror",
               "-fvisibility=hidden", "-Wl,-z,nodelete", "-o", str(dest), str(source),
               f"-I{LOADER_SOURCE.parent}", f"-I{FMI3_HEADERS}",
               *(f"-D{k}={json.dumps(v)}" for k, v in defines.items()),
               *(f"-D{k}={int(v)}" for k, v in (extra_defines or {}).items()), *flags, "-ldl",
               "-lpthread"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise NativeBuildError(f"compiling the FMU's loader failed:\n{' '.join(command)}\n"
                               f"{done.stderr}")
    return dest


def build_id(files: dict[str, bytes]) -> str:
    """Digest of the bundled Python sources: the suffix of the private module names."""
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + files[name] + b"\0")
    return digest.hexdigest()[:12]


def entry_module_name(ident: str) -> str:
    return f"_iceimpact_{ident}_fmu"


def package_for_native_hosts(fmu: Path, slave_name: str = SLAVE_NAME) -> None:
    """Rearrange a PythonFMU-built FMU as described above (Linux x86_64 builds only).

    ``slave_name`` is the model identifier, the slave's module and class name (``IceImpact``
    above; ``ModalStructure`` for :func:`build_modal`).
    """
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
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


# ModalStructure.fmu ------------------------------------------------------------------------------
# The structure FMU of docs/explanation/coupling.md: a linear structure given by its modes
# (iceimpact.modal), its variables in the contract table iceimpact.modal.contract. Built like
# IceImpact.fmu (the same bundle, requirements and native-host packaging), from
# fmu_src/ModalStructure.py.

MODAL_SLAVE_NAME = "ModalStructure"


def build_modal(dest: str | Path = ROOT / "dist", source_dir: str | Path = FMU_SRC) -> Path:
    """Build ``<dest>/ModalStructure.fmu`` from ``<source_dir>/ModalStructure.py`` and the
    ``iceimpact`` package (its contract: :mod:`iceimpact.modal.contract`)."""
    return build_slave(MODAL_SLAVE_NAME, "iceimpact.modal.contract", dest, source_dir)


# Standalone FMUs ---------------------------------------------------------------------------------
# ``python build_fmu.py --standalone`` writes dist/standalone/<id>.fmu: the FMU above plus its own
# CPython runtime, for a Linux x86_64 machine with no Python at all. Laid out as a prefix under
# binaries/linux64/python (the loader, compiled with BUNDLED_PYTHON, sets it as the runtime's home
# and module path):
#
#   lib/libpython3.X.so.1.0          the build's libpython
#   lib/preload.list, lib/lib*.so*   libraries outside glibc that the shipped modules need (libffi)
#   lib/python3.X/                   the standard library modules the core imports, lib-dynload
#   lib/python3.X/site-packages/     numpy and the scipy subpackages the core imports
#
# What the core imports is measured (:func:`imported_modules`: a probe drives the slave through
# every method, drag law, structure model, a refused parameter and its state), then whole
# packages are taken, less tests, headers and type stubs; every .py is compiled once to an
# unchecked-hash .pyc (a zip keeps mtimes to 2 s only, so a timestamp .pyc would be stale).

STANDALONE_DIR = "standalone"
BUNDLED_HOME = f"binaries/{NATIVE_PLATFORM}/python"  # loader.c: BUNDLED_HOME under its folder
#: Third-party packages the standalone runtime carries, with their vendored libraries.
BUNDLED_PACKAGES = ("numpy", "scipy")
#: Folders of a package that no import needs, and those dropped unless the probe imported them.
_TRIM_DIRS = {"tests", "test", "__pycache__", "include", "_pyinstaller", "doc", "docs",
              "benchmarks", "idlelib", "tkinter", "turtledemo", "ensurepip", "lib2to3",
              "pydoc_data"}
_TRIM_UNLESS_IMPORTED = {"f2py", "distutils", "typing", "testing", "unittest", "tomllib"}
_TRIM_SUFFIXES = (".pyi", ".pxd", ".pyx", ".h", ".c", ".cpp", ".a", ".pc", ".txt", ".md",
                  ".f", ".f90", ".orig")
#: Standard-library modules taken even when the probe does not import them: the start-up's
#: codecs and the modules that formatting an exception's traceback needs.
_STDLIB_ALWAYS = ("encodings", "os", "traceback", "linecache", "tokenize", "token", "warnings",
                  "codecs", "io", "abc", "stat", "posixpath", "genericpath", "_collections_abc",
                  "_sitebuiltins", "weakref", "copyreg", "re", "enum", "functools", "keyword",
                  "reprlib", "operator", "types", "collections", "contextlib",
                  # hashlib's built-in digests, used in place of OpenSSL's (_DYNLOAD_LEFT_OUT)
                  "_md5", "_sha1", "_sha256", "_sha512", "_sha3", "_blake2")
#: Libraries every Linux x86_64 machine has (glibc's); anything else a shipped binary needs
#: outside the FMU is bundled.
_SYSTEM_LIBRARIES = re.compile(
    r"^(linux-vdso|ld-linux|libc|libm|libdl|librt|libpthread|libutil|libresolv|libmvec"
    # the C++ runtime too: a C++ host has its own loaded, and a second copy must not come in
    r"|libgcc_s)\b|^libstdc\+\+")
#: Extension modules left out: their libraries (OpenSSL) are large, and the modules that import
#: them fall back to their built-in code without them (hashlib's own digests).
_DYNLOAD_LEFT_OUT = ("_hashlib", "_ssl")

PROBE = r'''
import importlib, json, sys, xml.etree.ElementTree as ET
resources, kind = sys.argv[1], sys.argv[2]
sys.path.insert(0, resources)
module = open(resources + "/slavemodule.txt").read().strip()
cls = getattr(importlib.import_module(module), kind)
md = ET.parse(resources + "/../modelDescription.xml").getroot()
refs = {v.get("name"): (int(v.get("valueReference")), v[0].tag)
        for v in md.iter("ScalarVariable")}

def setv(slave, name, value):
    vr, tag = refs[name]
    getattr(slave, "set_" + tag.lower())([vr], [value])

def run(values, steps=300, inputs=()):
    slave = cls(instance_name="probe", resources=resources, visible=False)
    slave.setup_experiment(0.0, None, None)
    for name, value in values.items():
        setv(slave, name, value)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    for k in range(steps):
        for name, value in inputs:
            setv(slave, name, value)
        slave.do_step(k * 1e-3, 1e-3)
    for tag in ("Real", "Integer", "Boolean"):
        vrs = [vr for vr, t in refs.values() if t == tag]
        getattr(slave, "get_" + tag.lower())(vrs)
    state = slave._get_fmu_state()
    slave._set_fmu_state(cls._fmu_state_from_bytes(cls._fmu_state_to_bytes(state)))
    slave.do_step(steps * 1e-3, 1e-3)
    slave.terminate()

scenes = json.loads(sys.argv[3])
for values, inputs in scenes:
    try:
        run(values, inputs=[tuple(i) for i in inputs])
    except Exception:
        pass
try:  # a state that is no state: refused
    cls._fmu_state_from_bytes(b"not a state")
except Exception:
    pass
print(json.dumps(sorted(sys.modules)))
'''

#: The probe's scenes per FMU: (parameters, inputs held every step).
PROBE_SCENES = {
    SLAVE_NAME: [
        ({"ice.M": 800.0}, []),
        ({"ice.M": 800.0, "solver.method": 2}, []),
        ({"ice.M": 800.0, "solver.method": 3, "drag.model": 2, "impact.e": 0.0}, []),
        ({"ice.M": 800.0, "solver.method": 3, "solver.ode_method": 2}, []),
        ({"ice.M": 800.0, "structure.Cd": 1.0, "structure.A": 2.0, "structure.Ca": 1.0,
          "structure.V": 1.0, "drag.model": 2}, []),
        ({"structure.model": 2, "ice.M": 800.0},
         [("structure.x_in", 0.0), ("structure.v_in", 0.0), ("structure.a_in", 0.0)]),
        ({"structure.m": -1.0}, []),
    ],
    MODAL_SLAVE_NAME: [({}, [("force", 1000.0)]), ({"modes": 2}, [("force", 10.0)])],
}


def imported_modules(fmu_dir: Path, slave_name: str) -> list[str]:
    """The modules the FMU's slave imports (sys.modules of a probe run in a fresh process)."""
    scenes = PROBE_SCENES[slave_name]
    names = {name for values, inputs in scenes for name in [*values, *(i[0] for i in inputs)]}
    described = ET.parse(fmu_dir / "modelDescription.xml").getroot()
    known = {v.get("name") for v in described.iter("ScalarVariable")}
    scenes = [(({k: v for k, v in values.items() if k in known}),
               [i for i in inputs if i[0] in known]) for values, inputs in scenes]
    if names - known:
        warnings.warn(f"the probe of {slave_name} skips unknown variables {sorted(names - known)}",
                      stacklevel=2)
    done = subprocess.run(
        [sys.executable, "-c", PROBE, str(fmu_dir / "resources"), slave_name, json.dumps(scenes)],
        capture_output=True, text=True, env={**os.environ, "ICEIMPACT_PURE": "1"})
    if done.returncode != 0:
        raise NativeBuildError(f"the import probe of {slave_name} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _trimmed_copy(source: Path, target: Path, package: str = "",
                  modules: frozenset[str] = frozenset()) -> None:
    """Copy the package folder ``source`` (imported as ``package``), less what no import needs:
    _TRIM_DIRS, _TRIM_SUFFIXES, compiled test modules, and _TRIM_UNLESS_IMPORTED folders none of
    whose modules are in ``modules``."""
    def ignore(folder: str, names: list[str]) -> list[str]:
        dotted = ".".join(filter(None, [package, *Path(folder).relative_to(source).parts]))
        dropped = []
        for n in names:
            if os.path.isdir(os.path.join(folder, n)):
                if n in _TRIM_DIRS or (n in _TRIM_UNLESS_IMPORTED and not any(
                        m == f"{dotted}.{n}" or m.startswith(f"{dotted}.{n}.")
                        for m in modules)):
                    dropped.append(n)
            elif _unneeded_file(n):
                dropped.append(n)
        return dropped
    shutil.copytree(source, target, ignore=ignore, symlinks=False)


def _unneeded_file(name: str) -> bool:
    """A file no import needs: sources of extensions, headers, stubs, stale .pyc, and numpy's
    compiled test modules."""
    return (name.endswith(_TRIM_SUFFIXES) or name.endswith(".pyc")
            or re.match(r"_\w*tests?\.cpython", name) is not None)


def _needed_libraries(binary: Path) -> list[tuple[str, Path]]:
    """(soname, path) of the shared libraries ``binary`` needs from outside its own folders."""
    done = subprocess.run(["ldd", str(binary)], capture_output=True, text=True)
    found = []
    for line in done.stdout.splitlines():
        match = re.match(r"\s*(\S+) => (/\S+)", line)
        if match and not _SYSTEM_LIBRARIES.match(match.group(1)):
            found.append((match.group(1), Path(match.group(2))))
    return found


def bundle_runtime(home: Path, modules: list[str]) -> dict:
    """Lay out the runtime described above under ``home`` for the measured ``modules``;
    returns what was bundled (for python.json)."""
    version = python_version()
    lib = home / "lib"
    stdlib_target = lib / f"python{version}"
    site_target = stdlib_target / "site-packages"
    dynload_target = stdlib_target / "lib-dynload"
    for folder in (site_target, dynload_target):
        folder.mkdir(parents=True, exist_ok=True)
    library, soname = libpython()
    if library is None:
        raise NativeBuildError(
            f"a standalone FMU carries the build's libpython, and this Python ({sys.base_prefix}) "
            "has none: build with a Python configured with --enable-shared (pyenv: "
            "PYTHON_CONFIGURE_OPTS=--enable-shared)")
    shutil.copy2(library, lib / soname)
    bundled: dict = {"libpython": soname}

    measured = frozenset(modules)
    stdlib = Path(sysconfig.get_paths()["stdlib"])
    dynload = stdlib / "lib-dynload"
    tops = sorted({name.split(".")[0] for name in modules} | set(_STDLIB_ALWAYS))
    taken: list[str] = []
    binaries: list[Path] = [lib / soname]
    for top in tops:
        if (stdlib / top / "__init__.py").exists():
            _trimmed_copy(stdlib / top, stdlib_target / top, top, measured)
        elif (stdlib / f"{top}.py").exists():
            shutil.copy2(stdlib / f"{top}.py", stdlib_target / f"{top}.py")
        elif top in _DYNLOAD_LEFT_OUT:
            continue
        else:
            extensions = list(dynload.glob(f"{top}.*.so")) if dynload.is_dir() else []
            if not extensions:
                continue  # built in, frozen, or not of the standard library
            for extension in extensions:
                shutil.copy2(extension, dynload_target / extension.name)
                binaries.append(dynload_target / extension.name)
        taken.append(top)
    import importlib.util

    packages = {}
    for package in BUNDLED_PACKAGES:
        spec = importlib.util.find_spec(package)
        source = Path(next(iter(spec.submodule_search_locations)))
        target = site_target / package
        if package == "scipy":
            # the subpackages the core imports (with scipy's private _lib), not all of scipy
            used = sorted({n.split(".")[1] for n in modules
                           if n.startswith("scipy.") and n.count(".") >= 1})
            target.mkdir()
            for entry in source.iterdir():
                if entry.is_dir() and entry.name not in used:
                    continue
                if entry.is_dir():
                    _trimmed_copy(entry, target / entry.name, f"scipy.{entry.name}", measured)
                elif not _unneeded_file(entry.name):
                    shutil.copy2(entry, target / entry.name)
            packages[package] = used
        else:
            _trimmed_copy(source, target, package, measured)
            packages[package] = ["all"]
        vendored = source.parent / f"{package}.libs"
        if vendored.is_dir():
            shutil.copytree(vendored, site_target / vendored.name)
        binaries += list(target.rglob("*.so"))

    # libraries outside glibc and outside the bundled packages (which carry theirs): bundled
    preload: list[str] = []
    for binary in binaries:
        for soname_needed, path in _needed_libraries(binary):
            if str(path).startswith(str(home)) or soname_needed in preload:
                continue
            if soname_needed.startswith("libpython"):
                continue
            shutil.copy2(path, lib / soname_needed)
            preload.append(soname_needed)
    (lib / "preload.list").write_text("".join(f"{name}\n" for name in preload))

    import compileall
    import py_compile

    compileall.compile_dir(str(stdlib_target), quiet=2, workers=0, ddir=None,
                           invalidation_mode=py_compile.PycInvalidationMode.UNCHECKED_HASH)
    return {**bundled, "stdlib": taken, "packages": packages, "libraries": preload}


def make_standalone(fmu: Path, dest: Path, slave_name: str = SLAVE_NAME) -> Path:
    """Write ``dest/<slave_name>.fmu``: ``fmu`` (a build of :func:`build_slave`) with its own
    CPython runtime, for Linux x86_64 hosts with no Python (see above)."""
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise NativeBuildError("a standalone FMU is built on Linux x86_64 only")
    dest = Path(dest).resolve()
    dest.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="iceimpact_standalone_") as tmp:
        root = Path(tmp) / "fmu"
        with zipfile.ZipFile(fmu) as src:
            src.extractall(root)
        modules = imported_modules(root, slave_name)
        shutil.rmtree(root / "binaries" / "win64", ignore_errors=True)  # Linux only
        bundled = bundle_runtime(root / BUNDLED_HOME, modules)
        loader = root / "binaries" / NATIVE_PLATFORM / f"{slave_name}.so"
        compile_loader(loader, None, bundled["libpython"], f"pythonfmu/{slave_name}.so",
                       bundled_python=True)
        config_path = root / "resources" / "iceimpact_fmu" / "python.json"
        config = json.loads(config_path.read_text())
        site = f"../{BUNDLED_HOME}/lib/python{python_version()}/site-packages"
        config.update(prefix=None, libpython=None, site=[site], standalone=bundled)
        config_path.write_text(json.dumps(config, indent=2) + "\n")
        description = root / "modelDescription.xml"
        description.write_bytes(description.read_bytes().replace(
            b'needsExecutionTool="true"', b'needsExecutionTool="false"'))
        target = dest / f"{slave_name}.fmu"
        tmp_fmu = target.with_suffix(".fmu.tmp")
        with zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as dst:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    dst.write(path, path.relative_to(root).as_posix())
        tmp_fmu.replace(target)
    return target


# The system file --------------------------------------------------------------------------------
#: The coupled system of examples/system/ (IceImpact.fmu on ModalStructure.fmu), written beside the
#: FMUs when both are built: one file that FMPy, ECOS, libcosim and OMSimulator load as it is
#: (docs/how-to/couple-to-a-structure.md, "The system file in five masters").
SYSTEM_FILE = "IceOnStructure.ssp"
SYSTEM_SCRIPT = ROOT / "examples" / "system" / "system.py"


def write_system(dest: str | Path) -> Path:
    """Write ``<dest>/IceOnStructure.ssp`` from the two FMUs built in ``dest``."""
    spec = importlib.util.spec_from_file_location("iceimpact_system_example", SYSTEM_SCRIPT)
    system = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(system)
    return system.write_ssp(Path(dest), Path(dest) / SYSTEM_FILE)


# FMI 3.0 ------------------------------------------------------------------------------------------
# dist/IceImpact3.fmu and dist/ModalStructure3.fmu: IceImpact.fmu and ModalStructure.fmu as FMI 3.0
# Co-Simulation FMUs. Each is made from the FMI 2.0 FMU itself (fmi3_from_fmi2: the same slave,
# model core and resources, byte for byte), and a standalone one from the standalone FMI 2.0 FMU:
#
#   modelDescription.xml                      FMI 3.0, converted from the FMI 2.0 one
#                                             (fmi3_model_description: the same variables,
#                                             value references, units, ranges, start values,
#                                             descriptions, dependencies, default experiment)
#   binaries/x86_64-linux/<id>3.so            fmu_native/fmi3.c, compiled here (it includes
#                                             the FMI 2.0 loader, loader.c)
#   binaries/x86_64-linux/pythonfmu/<id>.so   PythonFMU's FMI 2.0 library, as in the FMI 2.0 FMU
#   binaries/x86_64-linux/python/             the standalone runtime (standalone FMUs only)
#   resources/                                as in the FMI 2.0 FMU

FMI3_PLATFORM = "x86_64-linux"
#: The FMI 3.0 FMUs: the FMI 2.0 model identifier -> (the FMI 3.0 one, whether its steps may
#: return early, at contact events).
FMI3_MODELS = {SLAVE_NAME: ("IceImpact3", True), MODAL_SLAVE_NAME: ("ModalStructure3", False)}
#: FMI 2.0 ModelStructure lists -> FMI 3.0 elements.
_FMI3_STRUCTURE = {"Outputs": "Output", "Derivatives": "ContinuousStateDerivative",
                   "InitialUnknowns": "InitialUnknown"}
_FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def fmi3_model_description(xml: bytes, model_name: str, model_identifier: str,
                           returns_early: bool, time_reference: int,
                           standalone: bool = False) -> bytes:
    """The FMI 3.0 modelDescription.xml of an FMI 2.0 one completed by
    :func:`complete_model_description` (so: of the contract table): the same model and
    variables, the FMI 3.0 types and attributes, dependencies by value reference, and the
    independent variable FMI 3.0 asks for, ``time``, with value reference ``time_reference``
    (the slave's REACHED_TIME: fmi3GetFloat64 of it gives the instance's time)."""
    src = ET.fromstring(xml)
    attrs = {key: src.get(key) for key in (
        "description", "author", "version", "license", "generationTool",
        "generationDateAndTime", "variableNamingConvention") if src.get(key) is not None}
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": model_name,
        "instantiationToken": "{" + src.get("guid").strip("{}") + "}", **attrs})
    cs = src.find("CoSimulation")
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": model_identifier,
        "needsExecutionTool": "false" if standalone else cs.get("needsExecutionTool", "true"),
        "canHandleVariableCommunicationStepSize": "true",
        "canBeInstantiatedOnlyOncePerProcess": cs.get("canBeInstantiatedOnlyOncePerProcess",
                                                      "false"),
        "canGetAndSetFMUState": cs.get("canGetAndSetFMUstate", "false"),
        "canSerializeFMUState": cs.get("canSerializeFMUstate", "false"),
        "hasEventMode": "true",
        "mightReturnEarlyFromDoStep": "true" if returns_early else "false",
        "canReturnEarlyAfterIntermediateUpdate": "false",
        "providesIntermediateUpdate": "false"})
    for tag in ("UnitDefinitions", "LogCategories", "DefaultExperiment"):
        node = src.find(tag)
        if node is not None:
            root.append(node)
    units = root.find("UnitDefinitions")
    if units is None:
        units = ET.Element("UnitDefinitions")
        root.insert(list(root).index(root.find("CoSimulation")) + 1, units)
    if not any(unit.get("name") == "s" for unit in units):  # the unit of time
        ET.SubElement(ET.SubElement(units, "Unit", name="s"), "BaseUnit", s="1")
        units[:] = sorted(units, key=lambda unit: unit.get("name"))
    for category in root.iterfind("LogCategories/Category"):
        category.set("description", category.get("description", "").replace("fmi2", "fmi3"))
    variables = ET.SubElement(root, "ModelVariables")
    ET.SubElement(variables, "Float64", name="time", valueReference=str(time_reference),
                  description="simulation time", causality="independent",
                  variability="continuous", unit="s")
    references = []
    for scalar in src.find("ModelVariables").findall("ScalarVariable"):
        typed = scalar[0]
        node = ET.SubElement(variables, _FMI3_TYPES[typed.tag], {
            key: scalar.get(key) for key in ("name", "valueReference", "description",
                                             "causality", "variability", "initial")
            if scalar.get(key) is not None})
        references.append(scalar.get("valueReference"))
        for key in ("unit", "min", "max", "nominal"):
            if typed.get(key) is not None:
                node.set(key, typed.get(key))
        if typed.get("start") is not None:
            if typed.tag == "String":
                ET.SubElement(node, "Start", value=typed.get("start"))
            else:
                node.set("start", typed.get("start"))
    structure = ET.SubElement(root, "ModelStructure")
    for tag in ("Outputs", "Derivatives", "InitialUnknowns"):
        for unknown in src.find("ModelStructure").iterfind(f"{tag}/Unknown"):
            item = ET.SubElement(structure, _FMI3_STRUCTURE[tag], valueReference=references[
                int(unknown.get("index")) - 1])
            if unknown.get("dependencies") is not None:
                item.set("dependencies", " ".join(
                    references[int(i) - 1] for i in unknown.get("dependencies").split()))
                item.set("dependenciesKind", unknown.get("dependenciesKind", ""))
    text = ET.tostring(root, encoding="unicode")
    pretty = minidom.parseString(text).toprettyxml(indent="  ", encoding="UTF-8")
    return b"\n".join(line for line in pretty.splitlines() if line.strip()) + b"\n"


def fmi3_from_fmi2(fmu: Path, dest: str | Path, bundled_python: bool = False) -> Path:
    """Write ``<dest>/<id>3.fmu``, the FMI 3.0 FMU made of ``fmu``, the FMI 2.0 FMU ``<id>.fmu``
    (a build of :func:`build_slave`, or with ``bundled_python`` of :func:`make_standalone`)."""
    from iceimpact.fmi.lifecycle import EARLY_RETURN, REACHED_TIME
    from iceimpact.fmi.slave_base import FMI3_CHANNEL

    with zipfile.ZipFile(fmu) as src:
        entries = {info.filename: src.read(info) for info in src.infolist()}
    model = ET.fromstring(entries["modelDescription.xml"]).find("CoSimulation").get(
        "modelIdentifier")
    identifier, returns_early = FMI3_MODELS[model]
    old, new = f"binaries/{NATIVE_PLATFORM}/", f"binaries/{FMI3_PLATFORM}/"
    out: dict[str, bytes] = {}
    for name, data in entries.items():
        if name.startswith("binaries/") and not name.startswith(old):
            continue  # (PythonFMU's Windows library: FMI 2.0 only)
        if name == f"{old}{model}.so":
            continue  # the FMI 2.0 loader: compiled into the FMI 3.0 library below
        if name == "modelDescription.xml":
            data = fmi3_model_description(data, model, identifier, returns_early,
                                          FMI3_CHANNEL[REACHED_TIME][0],
                                          standalone=bundled_python)
        elif name == "resources/iceimpact_fmu/python.json":
            config = json.loads(data.replace(old.encode(), new.encode()))
            config["model_identifier"] = identifier  # (the boot module's messages name it)
            data = (json.dumps(config, indent=2) + "\n").encode()
        out[new + name[len(old):] if name.startswith(old) else name] = data
    with tempfile.TemporaryDirectory(prefix="iceimpact_fmi3_") as tmp:
        library = Path(tmp) / f"{identifier}.so"
        options = dict(source=FMI3_SOURCE, model_identifier=identifier,
                       extra_defines={"EARLY_RETURN_VR": FMI3_CHANNEL[EARLY_RETURN][0],
                                      "REACHED_TIME_VR": FMI3_CHANNEL[REACHED_TIME][0]})
        if bundled_python:
            compile_loader(library, None, config["standalone"]["libpython"],
                           f"pythonfmu/{model}.so", bundled_python=True, **options)
        else:
            path, soname = libpython()
            compile_loader(library, path, soname, f"pythonfmu/{model}.so", **options)
        out[f"{new}{identifier}.so"] = library.read_bytes()
    target = Path(dest).resolve() / f"{identifier}.fmu"
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_fmu = target.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED,
                         compresslevel=9 if bundled_python else None) as dst:
        for name in sorted(out):
            dst.writestr(name, out[name])
    tmp_fmu.replace(target)
    return target


def build_fmi3(model: str = SLAVE_NAME, dest: str | Path = ROOT / "dist",
               standalone_dest: str | Path | None = None, fmu: Path | None = None,
               standalone: Path | None = None) -> Path:
    """Build ``<dest>/<model>3.fmu`` (FMI 3.0; ``model``: IceImpact or ModalStructure) from the
    FMI 2.0 FMU ``fmu`` (default: built here), and with ``standalone_dest`` its standalone
    variant there, from the standalone FMI 2.0 FMU ``standalone`` (default: made here)."""
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise NativeBuildError("the FMI 3.0 FMUs are built on Linux x86_64 only")
    with tempfile.TemporaryDirectory(prefix="iceimpact_fmi2_of_3_") as tmp:
        if fmu is None:
            fmu = (build if model == SLAVE_NAME else build_modal)(tmp)
        target = fmi3_from_fmi2(fmu, dest)
        if standalone_dest is not None:
            if standalone is None:
                standalone = make_standalone(fmu, Path(tmp) / STANDALONE_DIR, model)
            fmi3_from_fmi2(standalone, standalone_dest, bundled_python=True)
    return target


def _with_standalone(builder, name: str):
    """A builder of BUILDERS: ``(dest, standalone_dest=None) -> FMU``."""
    def build_it(dest: str | Path, standalone_dest: str | Path | None = None) -> Path:
        fmu = builder(dest)
        if standalone_dest is not None:
            make_standalone(fmu, Path(standalone_dest), name)
        return fmu
    return build_it


def _fmi3_builder(model: str):
    """A builder of BUILDERS for ``<model>3.fmu``: from ``<model>.fmu`` (and its standalone
    variant) in the same folders if there, else from an FMI 2.0 build of its own."""
    def build_it(dest: str | Path, standalone_dest: str | Path | None = None) -> Path:
        fmu = Path(dest) / f"{model}.fmu"
        standalone = None if standalone_dest is None else Path(standalone_dest) / fmu.name
        if not fmu.exists() or (standalone is not None and not standalone.exists()):
            fmu = standalone = None
        return build_fmi3(model, dest, standalone_dest, fmu=fmu, standalone=standalone)
    return build_it


#: What ``python build_fmu.py --fmu NAME`` builds: NAME -> ``(dest, standalone_dest) -> FMU``,
#: in this order (the FMI 3.0 FMUs from the FMI 2.0 ones built just before).
BUILDERS = {
    SLAVE_NAME: _with_standalone(build, SLAVE_NAME),
    MODAL_SLAVE_NAME: _with_standalone(build_modal, MODAL_SLAVE_NAME),
    **{identifier: _fmi3_builder(model) for model, (identifier, _) in FMI3_MODELS.items()},
}


def variables_table(fmu: str | Path) -> str:
    """The variables of a built FMU as the contract's Markdown table (the documentation's page
    of FMU variables, docs/reference/fmu-variables.md, is made from the same table)."""
    from fmpy import read_model_description

    from iceimpact.contract import markdown_table

    names = [v.name for v in read_model_description(str(fmu)).modelVariables]
    table = markdown_table()
    missing = [n for n in names if f"| `{n}` |" not in table]
    if missing:
        raise ValueError(f"variables of the FMU missing from the contract: {missing}")
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dest", default=str(ROOT / "dist"),
                        help="output folder (default: dist)")
    parser.add_argument("--fmu", choices=["all", *BUILDERS], default="all",
                        help="which FMU to build (default: all, i.e. IceImpact.fmu, "
                             "ModalStructure.fmu, IceImpact3.fmu and ModalStructure3.fmu)")
    parser.add_argument("--standalone", action="store_true",
                        help="also write <dest>/standalone/<FMU>.fmu, each with its own CPython "
                             "runtime, numpy and scipy, for Linux x86_64 machines without Python")
    parser.add_argument("--variables-table", action="store_true",
                        help="also print the variables of IceImpact.fmu as a Markdown table "
                             "(the contract's table, as the documentation shows it)")
    args = parser.parse_args(argv)
    from fmpy.validation import validate_fmu

    failed = 0
    for name, builder in BUILDERS.items():
        if args.fmu not in ("all", name):
            continue
        standalone_dest = Path(args.dest) / STANDALONE_DIR if args.standalone else None
        fmu = builder(args.dest, standalone_dest)
        if args.variables_table and name == SLAVE_NAME:
            print(variables_table(fmu))
        problems = validate_fmu(str(fmu))
        for problem in problems:
            print(f"validation: {problem}", file=sys.stderr)
        print(f"built {fmu}" + ("" if not problems else f" ({len(problems)} validation "
                                                       "problems)"))
        failed += bool(problems)
        if standalone_dest is not None:
            standalone = standalone_dest / fmu.name
            print(f"built {standalone} ({standalone.stat().st_size / 1e6:.0f} MB, with its own "
                  f"Python {python_version()}, numpy and scipy)")
    if args.fmu == "all":
        print(f"built {write_system(args.dest)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
