"""Start-up of IceImpact.fmu inside any host: Python environment, private core, slave class.

``build_fmu.py`` bundles this file as ``resources/iceimpact_fmu/boot.py`` and writes the entry
module PythonFMU imports (``resources/_iceimpact_<id>_fmu.py``), which calls :func:`load_slave`.
On the first call it

1. makes the FMU's requirements (numpy, scipy) importable: if the Python of the process cannot find
   them, the site-packages folders recorded at build time (``resources/iceimpact_fmu/python.json``)
   are put on ``sys.path``, as long as the Python has the recorded minor version (any other
   Python runs the FMU with the numpy and scipy it has itself); if they still cannot be imported,
   or their versions are older than the requirements allow, it raises ImportError with a message
   that names what is missing or too old, the versions allowed, where it was looked for and how
   to install them;
2. loads the model core from ``resources/iceimpact`` under a private name (``_iceimpact_<id>``,
   ``<id>`` a digest of the bundled sources), so that a host that imported another ``iceimpact``
   (or another build of this FMU) never makes the FMU run a core it was not built with;
3. loads the slave (``resources/iceimpact_fmu/<class name>.py``: ``IceImpact.py``, or
   ``ModalStructure.py`` in ModalStructure.fmu) under a private name too; while its
   body runs, ``import iceimpact...`` resolves to the private core (the host's own modules of
   that name, if any, are put back afterwards).

Only the standard library is used here, and no extension module is imported before the
environment is set up.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.abc
import importlib.util
import json
import os
import sys

CORE = "iceimpact"  # the package name the slave imports


_loaded: dict[str, type] = {}


def _resources() -> str:
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _requirement_names(requirements: list[str]) -> list[str]:
    return [name for name, _ in map(_requirement, requirements) if name]


def _requirement(requirement: str) -> tuple[str, list[tuple[str, str]]]:
    """``"scipy>=1.10,<2"`` -> ``("scipy", [(">=", "1.10"), ("<", "2")])`` (the forms
    requirements.txt uses here; extras and markers are dropped)."""
    text = requirement.split(";")[0].strip()
    name = text
    for mark in "<>=!~[ ":
        name = name.split(mark)[0]
    rest = text[len(name):].strip()
    if rest.startswith("["):
        rest = rest[rest.find("]") + 1:]
    specifiers = []
    for part in filter(None, (p.strip() for p in rest.split(","))):
        operator = next((op for op in ("~=", "==", "!=", ">=", "<=", ">", "<") if
                         part.startswith(op)), None)
        if operator:
            specifiers.append((operator, part[len(operator):].strip()))
    return name.strip(), specifiers


def _release(version: str) -> tuple[int, ...]:
    """The release numbers a version starts with: ``"1.26.4"``, ``"2.0.0rc1"`` -> (2, 0, 0)."""
    numbers = []
    for part in version.split("."):
        digits = ""
        for char in part:
            if not char.isdigit():
                break
            digits += char
        if not digits:
            break
        numbers.append(int(digits))
        if len(digits) < len(part):
            break
    return tuple(numbers)


def _allows(specifiers: list[tuple[str, str]], version: str) -> bool:
    """Whether ``version`` meets every specifier (release numbers compared, padded with zeros)."""
    have = _release(version)
    if not have:
        return True  # a version that cannot be read is not refused
    for operator, wanted in specifiers:
        want = _release(wanted.rstrip(".*"))
        size = max(len(have), len(want))
        a, b = have + (0,) * (size - len(have)), want + (0,) * (size - len(want))
        if operator == "~=":
            ok = a >= b and a[:max(len(want) - 1, 1)] == b[:max(len(want) - 1, 1)]
        elif operator in ("==", "!=") and wanted.endswith(".*"):
            ok = (a[:len(want)] == want) == (operator == "==")
        else:
            ok = {"==": a == b, "!=": a != b, ">=": a >= b, "<=": a <= b, ">": a > b,
                  "<": a < b}[operator]
        if not ok:
            return False
    return True


def _installed_version(name: str, module=None) -> str | None:
    version = getattr(module, "__version__", None)
    if isinstance(version, str):
        return version
    try:
        from importlib import metadata

        return metadata.version(name)
    except Exception:
        return None


def _tidy_sys_path(resources: str) -> None:
    """PythonFMU puts ``resources`` first on sys.path at every instantiation: keep one."""
    while sys.path.count(resources) > 1:
        sys.path.reverse()
        sys.path.remove(resources)
        sys.path.reverse()


def prepare_environment(config: dict, resources: str) -> None:
    """Make the FMU's requirements importable, or raise ImportError saying what is missing."""
    _tidy_sys_path(resources)
    names = _requirement_names(config.get("requirements", []))
    version = config.get("python", "")
    same_python = version == "{}.{}".format(*sys.version_info[:2])
    # a relative folder is the FMU's own (a standalone FMU's bundled site-packages)
    recorded = [os.path.normpath(os.path.join(resources, d)) for d in config.get("site", [])]
    recorded = [d for d in recorded if os.path.isdir(d)]
    if same_python and any(importlib.util.find_spec(n) is None for n in names):
        position = sys.path.index(resources) + 1 if resources in sys.path else 0
        sys.path[position:position] = [d for d in recorded if d not in sys.path]
    problems: list[str] = []
    first_error: Exception | None = None
    for requirement in config.get("requirements", []):
        name, specifiers = _requirement(requirement)
        if not name:
            continue
        module = sys.modules.get(name)
        if module is None and problems:
            # a requirement that failed may be what this one imports (scipy imports numpy):
            # looked up, not imported
            if importlib.util.find_spec(name) is None:
                problems.append(f"cannot import {name} (no module named {name!r})")
                continue
        elif module is None:
            try:
                module = importlib.import_module(name)
            except Exception as exc:
                problems.append(f"cannot import {name} ({exc!r})")
                first_error = first_error or exc
                continue
        version = _installed_version(name, module)
        if version is None or _allows(specifiers, version):
            continue
        older = any(op in (">=", ">", "~=") and _release(version) < _release(wanted)
                    for op, wanted in specifiers)
        found = getattr(module, "__file__", None)
        where = f" (in {os.path.dirname(os.path.dirname(found))})" if found else ""
        problems.append(f"{name} {version}{where} is {'too old' if older else 'not allowed'}: "
                        f"the FMU needs {requirement.strip()}")
    if problems:
        error = ImportError(_missing_message(problems, config, resources, same_python, recorded))
        raise error from first_error


def _missing_message(problems: list[str], config: dict, resources: str, same_python: bool,
                     recorded: list[str]) -> str:
    version = config.get("python", "?")
    here = "{}.{}".format(*sys.version_info[:2])
    if not same_python:
        where = (f"this process runs Python {here}, the FMU was built with Python {version}: its "
                 f"recorded environment is not used")
    elif not recorded:
        where = ("the environment recorded when the FMU was built is not on this machine "
                 f"({', '.join(config.get('site', [])) or 'none recorded'})")
    else:
        where = f"looked in sys.path, which includes the recorded {', '.join(recorded)}"
    requirements = os.path.join(resources, "requirements.txt")
    fmu = config.get("model_identifier", "IceImpact")
    return (f"{fmu}.fmu needs {', '.join(config.get('requirements', []))} in the Python "
            f"of the host process (Python {here}, {sys.prefix}): {'; '.join(problems)}; "
            f"{where}. Install them for Python {here}: on Debian/Ubuntu, whose Python refuses "
            f"pip (externally managed), apt-get install python3-numpy python3-scipy; elsewhere "
            f"python{here} -m pip install -r {requirements}; or use the standalone {fmu}.fmu, "
            f"which carries its own Python, numpy and scipy (build_fmu.py --standalone)")


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """While the slave's body runs: ``iceimpact[.x]`` is the private core ``<private>[.x]``."""

    def __init__(self, private: str):
        self.private = private

    def find_spec(self, name, path=None, target=None):
        if not (name == CORE or name.startswith(CORE + ".")):
            return None
        module = importlib.import_module(self.private + name[len(CORE):])
        spec = importlib.util.spec_from_loader(name, self,
                                               is_package=hasattr(module, "__path__"))
        spec.loader_state = (module, module.__spec__)
        return spec

    def create_module(self, spec):
        return spec.loader_state[0]

    def exec_module(self, module):
        module.__spec__ = module.__spec__.loader_state[1]  # the import system replaced it


def _load(name: str, path: str, package_dir: str | None = None):
    spec = importlib.util.spec_from_file_location(
        name, path, submodule_search_locations=[package_dir] if package_dir else None)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _aliases_removed() -> dict:
    return {k: sys.modules.pop(k) for k in list(sys.modules)
            if k == CORE or k.startswith(CORE + ".")}


#: In the host's environment, "1" lets the FMU's core compile its kernels where the host's
#: Python has numba (iceimpact/compiled.py). Not the default: numba's machine code is
#: cached per user and found again by every fresh extraction of the same FMU, but importing
#: numba and readying its compiler still costs about 0.3 s of CPU and 120 MB per host process,
#: more than the kernels save in an FMU run (docs/explanation/speed.md#start-up-and-numbas-cache).
FMU_COMPILED_ENV = "ICEIMPACT_FMU_COMPILED"


@contextlib.contextmanager
def _flight_search_policy():
    """While the FMU's core loads: the pure flight search (ICEIMPACT_PURE=1, which
    flight_search reads at import), unless the host asked for the compiled one
    (FMU_COMPILED_ENV=1). The host's environment is given back as it was."""
    if os.environ.get(FMU_COMPILED_ENV, "") == "1":
        yield
        return
    before = os.environ.get("ICEIMPACT_PURE")
    os.environ["ICEIMPACT_PURE"] = "1"
    try:
        yield
    finally:
        if before is None:
            del os.environ["ICEIMPACT_PURE"]
        else:
            os.environ["ICEIMPACT_PURE"] = before


def load_slave(build_id: str, class_name: str = "IceImpact") -> type:
    """The slave class of this FMU build, loaded once per process (see the module docstring)."""
    key = f"{build_id}.{class_name}"
    if key in _loaded:
        _tidy_sys_path(_resources())
        return _loaded[key]
    resources = _resources()
    with open(os.path.join(resources, "iceimpact_fmu", "python.json")) as fh:
        config = json.load(fh)
    prepare_environment(config, resources)

    private = f"_{CORE}_{build_id}"
    if private not in sys.modules:
        core_dir = os.path.join(resources, CORE)
        with _flight_search_policy():
            _load(private, os.path.join(core_dir, "__init__.py"), core_dir)

    slave_name = f"{private}_slave"
    slave = sys.modules.get(slave_name)
    if slave is None:
        hosts = _aliases_removed()
        alias = _Alias(private)
        sys.meta_path.insert(0, alias)
        try:
            for name in [k for k in sys.modules if k == private or k.startswith(private + ".")]:
                sys.modules[CORE + name[len(private):]] = sys.modules[name]
            slave = _load(slave_name,
                          os.path.join(resources, "iceimpact_fmu", f"{class_name}.py"))
        finally:
            sys.meta_path.remove(alias)
            _aliases_removed()
            sys.modules.update(hosts)
    _loaded[key] = getattr(slave, class_name)
    return _loaded[key]
