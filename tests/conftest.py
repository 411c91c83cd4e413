"""Session fixtures: IceImpact.fmu (and IceImpact3.fmu, FMI 3.0) built once into a temporary
folder, extracted, described.

FMPy and the FMU helpers are imported by the fixtures that use them, so that the tests of the
core collect and run where the FMU extra is not installed."""

from __future__ import annotations

from pathlib import Path

import pytest

# An FMU run in this process (FMPy) puts its resources/, with a slim pythonfmu, first on sys.path:
# the installed builder is bound before any test runs one.
try:
    import pythonfmu.builder  # noqa: F401
except ImportError:  # (the FMU extra not installed: the FMU tests skip)
    pass


def _build_module():
    """build_fmu.py as a module (tests/fmu_host.py)."""
    from fmu_host import build_module

    return build_module()


def _extract(fmu: Path | str, unzipdir: Path) -> str:
    """The FMU unzipped into ``unzipdir``; its folder."""
    from fmpy import extract

    return extract(str(fmu), unzipdir=str(unzipdir))


@pytest.fixture(scope="session")
def fmu(tmp_path_factory) -> Path:
    return _build_module().build(tmp_path_factory.mktemp("dist"))


@pytest.fixture(scope="session")
def fmu_dir(fmu, tmp_path_factory) -> str:
    return _extract(fmu, tmp_path_factory.mktemp("IceImpact"))


@pytest.fixture(scope="session")
def model_description(fmu):
    from fmpy import read_model_description

    return read_model_description(str(fmu))


@pytest.fixture(scope="session")
def c_host(tmp_path_factory) -> Path:
    """The C master of tests/c_host/host.c, compiled once."""
    from native_host import C_HOST, compile_c

    return compile_c(C_HOST / "host.c", tmp_path_factory.mktemp("host") / "host", "-ldl")


@pytest.fixture(scope="session")
def c_host3(tmp_path_factory) -> Path:
    """The FMI 3.0 C master of tests/c_host/host3.c, compiled once (with the FMI 3.0 headers
    of fmu_native/fmi3)."""
    from native_host import C_HOST, ROOT, compile_c

    return compile_c(C_HOST / "host3.c", tmp_path_factory.mktemp("host3") / "host3",
                     f"-I{ROOT / 'fmu_native' / 'fmi3'}", "-ldl")


@pytest.fixture(scope="session")
def standalone_fmu(fmu, tmp_path_factory) -> Path:
    """The session's IceImpact.fmu made standalone (build_fmu.py --standalone)."""
    return _build_module().make_standalone(fmu, tmp_path_factory.mktemp("standalone"))


@pytest.fixture(scope="session")
def standalone_dir(standalone_fmu, tmp_path_factory) -> str:
    return _extract(standalone_fmu, tmp_path_factory.mktemp("standalone_x"))


@pytest.fixture(scope="session")
def fmus(fmu, tmp_path_factory) -> Path:
    """A folder with IceImpact.fmu (the session's build) and ModalStructure.fmu: the FMUs of the
    coupled system (examples/system)."""
    import shutil

    folder = tmp_path_factory.mktemp("system_fmus")
    shutil.copy(fmu, folder / "IceImpact.fmu")
    _build_module().build_modal(folder)
    return folder


@pytest.fixture(scope="session")
def fmu3(fmu, tmp_path_factory) -> Path:
    """IceImpact3.fmu (FMI 3.0), made of the session's IceImpact.fmu."""
    return _build_module().fmi3_from_fmi2(fmu, tmp_path_factory.mktemp("dist3"))


@pytest.fixture(scope="session")
def fmu3_dir(fmu3, tmp_path_factory) -> str:
    return _extract(fmu3, tmp_path_factory.mktemp("IceImpact3"))


@pytest.fixture(scope="session")
def fmus3(fmu3, tmp_path_factory) -> Path:
    """A folder with IceImpact3.fmu (the session's build) and ModalStructure3.fmu."""
    import shutil

    folder = tmp_path_factory.mktemp("system_fmus3")
    shutil.copy(fmu3, folder / "IceImpact3.fmu")
    _build_module().build_fmi3("ModalStructure", folder)
    return folder


@pytest.fixture(scope="session")
def standalone_fmu3(standalone_fmu, tmp_path_factory) -> Path:
    """IceImpact3.fmu made standalone (build_fmu.py --standalone): made of the session's
    standalone IceImpact.fmu."""
    return _build_module().fmi3_from_fmi2(standalone_fmu, tmp_path_factory.mktemp("standalone3"),
                                         bundled_python=True)


@pytest.fixture(scope="session")
def standalone3_dir(standalone_fmu3, tmp_path_factory) -> str:
    return _extract(standalone_fmu3, tmp_path_factory.mktemp("standalone3_x"))
