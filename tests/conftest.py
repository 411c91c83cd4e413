"""Session fixtures: IceImpact.fmu (and IceImpact3.fmu, FMI 3.0) built once into a temporary
folder, extracted, described."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from fmpy import extract, read_model_description

from fmu_host import build_module

# the search and cost scripts (tools/) that some tests drive
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))


@pytest.fixture(scope="session")
def fmu(tmp_path_factory) -> Path:
    return build_module().build(tmp_path_factory.mktemp("dist"))


@pytest.fixture(scope="session")
def fmu_dir(fmu, tmp_path_factory) -> str:
    return extract(str(fmu), unzipdir=str(tmp_path_factory.mktemp("IceImpact")))


@pytest.fixture(scope="session")
def model_description(fmu):
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
    return build_module().make_standalone(fmu, tmp_path_factory.mktemp("standalone"))


@pytest.fixture(scope="session")
def standalone_dir(standalone_fmu, tmp_path_factory) -> str:
    return extract(str(standalone_fmu), unzipdir=str(tmp_path_factory.mktemp("standalone_x")))


@pytest.fixture(scope="session")
def fmus(fmu, tmp_path_factory) -> Path:
    """A folder with IceImpact.fmu (the session's build) and ModalStructure.fmu: the FMUs of the
    coupled system (examples/system)."""
    import shutil

    folder = tmp_path_factory.mktemp("system_fmus")
    shutil.copy(fmu, folder / "IceImpact.fmu")
    build_module().build_modal(folder)
    return folder


@pytest.fixture(scope="session")
def fmu3(fmu, tmp_path_factory) -> Path:
    """IceImpact3.fmu (FMI 3.0), made of the session's IceImpact.fmu."""
    return build_module().fmi3_from_fmi2(fmu, tmp_path_factory.mktemp("dist3"))


@pytest.fixture(scope="session")
def fmu3_dir(fmu3, tmp_path_factory) -> str:
    return extract(str(fmu3), unzipdir=str(tmp_path_factory.mktemp("IceImpact3")))


@pytest.fixture(scope="session")
def fmus3(fmu3, tmp_path_factory) -> Path:
    """A folder with IceImpact3.fmu (the session's build) and ModalStructure3.fmu."""
    import shutil

    folder = tmp_path_factory.mktemp("system_fmus3")
    shutil.copy(fmu3, folder / "IceImpact3.fmu")
    build_module().build_fmi3("ModalStructure", folder)
    return folder


@pytest.fixture(scope="session")
def standalone_fmu3(standalone_fmu, tmp_path_factory) -> Path:
    """IceImpact3.fmu made standalone (build_fmu.py --standalone): made of the session's
    standalone IceImpact.fmu."""
    return build_module().fmi3_from_fmi2(standalone_fmu, tmp_path_factory.mktemp("standalone3"),
                                         bundled_python=True)


@pytest.fixture(scope="session")
def standalone3_dir(standalone_fmu3, tmp_path_factory) -> str:
    return extract(str(standalone_fmu3), unzipdir=str(tmp_path_factory.mktemp("standalone3_x")))
