"""The native side of every FMU: the C loader compiled for a Python.

PythonFMU's library (``binaries/linux64/<id>.so``) does not link libpython. The FMUs put a small
loader in front of it, compiled here from ``fmu_native/loader.c`` (FMI 2.0) or
``fmu_native/fmi3.c`` (FMI 3.0, which includes loader.c) with the building Python's libpython, or
with ``BUNDLED_PYTHON`` for a standalone FMU's own runtime. See docs/explanation/fmu-loader.md.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import warnings
from pathlib import Path

from .layout import ROOT

LOADER_SOURCE = ROOT / "fmu_native" / "loader.c"
FMI3_SOURCE = ROOT / "fmu_native" / "fmi3.c"
FMI3_HEADERS = ROOT / "fmu_native" / "fmi3"  # the FMI 3.0 standard's headers (2-Clause BSD)

NATIVE_PLATFORM = "linux64"
PYTHONFMU_LIBRARY = "pythonfmu/IceImpact.so"  # relative to binaries/linux64 (loader.c knows it)


class NativeBuildError(RuntimeError):
    """The native loader cannot be built on this machine (the message says what is missing)."""


def builds_native_loader() -> bool:
    """Whether this machine builds the native loaders: Linux on x86_64 only."""
    return sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")


def python_version() -> str:
    """The building Python's version, ``"3.X"``."""
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
    the runtime of a standalone FMU (:func:`fmu_build.standalone.make_standalone`) in a process
    without Python; that needs the build's Python.h. ``source`` is loader.c, or fmi3.c (the
    FMI 3.0 library, which includes it), with ``extra_defines`` (name -> integer);
    ``model_identifier`` names the FMU in the library's messages (default: PythonFMU's
    library's name)."""
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


