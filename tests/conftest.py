"""Session fixtures: IceImpact.fmu built once into a temporary folder, extracted, described."""

from __future__ import annotations

from pathlib import Path

import pytest
from fmpy import extract, read_model_description

from fmu_host import build_module


@pytest.fixture(scope="session")
def fmu(tmp_path_factory) -> Path:
    return build_module().build(tmp_path_factory.mktemp("dist"))


@pytest.fixture(scope="session")
def fmu_dir(fmu, tmp_path_factory) -> str:
    return extract(str(fmu), unzipdir=str(tmp_path_factory.mktemp("IceImpact")))


@pytest.fixture(scope="session")
def model_description(fmu):
    return read_model_description(str(fmu))
