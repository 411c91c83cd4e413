"""Standalone FMUs: an FMU with its own CPython runtime, numpy and scipy.

``python build_fmu.py --standalone`` writes dist/standalone/<id>.fmu: the FMU of
:func:`fmu_build.fmi2.build_slave` plus its own CPython runtime, for a Linux x86_64 machine with
no Python at all. Laid out as a prefix under binaries/linux64/python (the loader, compiled with
BUNDLED_PYTHON, sets it as the runtime's home and module path)::

    lib/libpython3.X.so.1.0          the build's libpython
    lib/preload.list, lib/lib*.so*   libraries outside glibc that the shipped modules need (libffi)
    lib/python3.X/                   the standard library modules the core imports, lib-dynload
    lib/python3.X/site-packages/     numpy and the scipy subpackages the core imports

What the core imports is measured (:func:`imported_modules`: the probe, :mod:`fmu_build.probe`,
drives the slave through every method, drag law, structure model, a refused parameter and its
state), then whole packages are taken, less tests, headers and type stubs; every .py is compiled
once to an unchecked-hash .pyc (a zip keeps mtimes to 2 s only, so a timestamp .pyc would be
stale).
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import warnings
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from .documentation import PAGE, documentation_page
from .layout import MODAL_SLAVE_NAME, SLAVE_NAME
from .native import (
    NATIVE_PLATFORM,
    NativeBuildError,
    builds_native_loader,
    compile_loader,
    libpython,
    python_version,
)

#: The probe program, run as a script in a fresh process.
PROBE = Path(__file__).resolve().with_name("probe.py")

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
        [sys.executable, "-P", str(PROBE), str(fmu_dir / "resources"), slave_name,
         json.dumps(scenes)],
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
    """Write ``dest/<slave_name>.fmu``: ``fmu`` (a build of :func:`fmu_build.fmi2.build_slave`)
    with its own CPython runtime, for Linux x86_64 hosts with no Python (see above)."""
    if not builds_native_loader():
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
        page = root / PAGE  # what the machine needs differs from the default build's page
        page.parent.mkdir(exist_ok=True)
        page.write_text(documentation_page(slave_name, "2.0", standalone=True))
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

