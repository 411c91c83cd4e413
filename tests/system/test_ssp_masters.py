"""IceOnStructure.ssp (examples/system/system.py), written once, loaded unchanged by five masters:
FMPy's simulate_ssp (with the SSP's own parameter set), ECOS (ecospy), libcosim's from_ssp_file
with no step size, OMSimulator's command line and OMSimulator's Python API.

All five are Jacobi schemes on the same 1 ms grid, so each must run the SSP's scene (the floe
impacting the structure, structure.model = 2 among its bindings) and equal the scripted FMPy
Jacobi loop run with the same parameters: bit for bit where the step sizes are identical (FMPy,
ECOS), to rounding where they differ in the last bits (libcosim counts integer nanoseconds,
OMSimulator adds h up and steps tNext - t; measured 5e-13 of the peak displacement, the impacts
amplifying rounding). libcosim and OMSimulator's Python API run in child processes, so that a
crash fails a test instead of ending pytest.
"""

from __future__ import annotations

import importlib.util
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

import system

ROOT = Path(__file__).resolve().parents[2]

#: The OMSimulator build, beside the repository (CI clones it with shared/ next to it).
OMSIMULATOR = ROOT.parent / "shared" / "tools" / "omsimulator"
NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations"}
#: max |x - x_ref| / max |x_ref| allowed against the FMPy Jacobi loop: 0 where the grid is the
#: loop's to the bit, rounding (measured 4.6e-13 and 4.8e-13) where the step sizes differ in
#: the last bits
TOLERANCE = {"FMPy simulate_ssp": 0.0, "ECOS": 0.0, "libcosim from_ssp_file": 1e-9,
             "OMSimulator CLI": 1e-9, "OMSimulator API": 1e-9}


def _need_omsimulator(python_api: bool = False) -> Path:
    if not (OMSIMULATOR / "bin" / "OMSimulator").is_file():
        pytest.skip(f"no OMSimulator build at {OMSIMULATOR} (../shared/tools/omsimulator)")
    if python_api:
        pytest.importorskip("lxml", reason="OMSimulator's Python package needs lxml")
    return OMSIMULATOR


def _need(module: str) -> None:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed")


MASTERS = ["FMPy simulate_ssp", "ECOS", "libcosim from_ssp_file", "OMSimulator CLI",
           "OMSimulator API"]


def run_master(master: str, ssp: Path) -> dict:
    """The SSP, as it is, through ``master``; libcosim and OMSimulator's Python API in a child
    process."""
    if master == "FMPy simulate_ssp":
        return system.fmpy_ssp_run(ssp)
    if master == "ECOS":
        pytest.importorskip("ecospy")
        return system.ecospy_run(ssp)
    if master == "libcosim from_ssp_file":
        _need("libcosimpy")
        return system.in_subprocess("libcosim_ssp_run", ssp)
    if master == "OMSimulator CLI":
        return system.omsimulator_cli_run(ssp, _need_omsimulator())
    return system.in_subprocess("omsimulator_api_run", ssp, _need_omsimulator(python_api=True))


@pytest.fixture(scope="module")
def ssp(fmus, tmp_path_factory) -> Path:
    return system.write_ssp(fmus, tmp_path_factory.mktemp("ssp") / "IceOnStructure.ssp")


@pytest.fixture(scope="module")
def reference(fmus) -> dict:
    """The scripted FMPy Jacobi loop with the SSP's parameters (its default 2 s at 1 ms)."""
    return system.fmpy_master(fmus, system.T_END, system.STEP, "jacobi")


@pytest.fixture(scope="module")
def runs() -> dict:
    """Each master's run, made when a test first asks for it."""
    return {}


def run(runs: dict, ssp: Path, master: str) -> dict:
    if master not in runs:
        runs[master] = run_master(master, ssp)
    return runs[master]


# What the SSP carries ----------------------------------------------------------------------------
def test_the_ssp_carries_what_each_master_reads(ssp):
    with zipfile.ZipFile(ssp) as z:
        assert sorted(z.namelist()) == ["SystemStructure.ssd", "resources/IceImpact.fmu",
                                        "resources/IceOnStructure.ssv",
                                        "resources/ModalStructure.fmu"]
        ssd = ElementTree.fromstring(z.read("SystemStructure.ssd"))
        ssv = ElementTree.fromstring(z.read(system.SSV))
    # libcosim: the OSP step in the DefaultExperiment; 2 s at 1 ms
    default = ssd.find("ssd:DefaultExperiment", NS)
    assert (default.get("startTime"), default.get("stopTime")) == ("0.0", "2.0")
    assert default.find(".//osp:FixedStepAlgorithm", NS).get("baseStepSize") == "0.001"
    assert system.experiment(ssp) == (0.0, 2.0, 1e-3)
    # OMSimulator: its fixed-step master (Jacobi) at the same step
    master = ssd.find("ssd:System/ssd:Annotations//oms:FixedStepMaster", NS)
    assert (master.get("description"), master.get("stepSize")) == ("oms-ma", "0.001")
    # FMPy: the inline bindings again in the .ssv, names prefixed by the component's
    inline = {f"{c.get('name')}.{p.get('name')}": next(iter(p)).get("value")
              for c in ssd.iterfind("ssd:System/ssd:Elements/ssd:Component", NS)
              for p in c.iterfind(".//ssv:Parameter", NS)}
    in_file = {p.get("name"): next(iter(p)).get("value") for p in ssv.iterfind(".//ssv:Parameter",
                                                                                  NS)}
    assert inline == in_file
    floe = system.ICE_COMPONENT
    assert inline[f"{floe}.structure.model"] == "2" and inline[f"{floe}.coupling.scheme"] == "2"


def test_the_component_names_survive_every_master(ssp):
    """OMSimulator strips a component's name from the front of a name bound to it (``ice.M`` on
    ``ice``); FMPy picks a component's parameters by the prefix of its name, without the dot."""
    with zipfile.ZipFile(ssp) as z:
        ssd = ElementTree.fromstring(z.read("SystemStructure.ssd"))
    components = {c.get("name"): [p.get("name") for p in c.iterfind(".//ssv:Parameter", NS)]
                  for c in ssd.iterfind("ssd:System/ssd:Elements/ssd:Component", NS)}
    assert sorted(components) == ["floe", "structure"]
    for name, bound in components.items():
        assert all(b.split(".")[0] != name for b in bound), (name, bound)
        assert not any(other.startswith(name) for other in components if other != name)


def test_write_ssp_refuses_names_a_master_would_lose(fmus, tmp_path, monkeypatch):
    """libcosim skips an unknown name with a warning; OMSimulator strips the component's name."""
    with pytest.raises(ValueError, match="'ice.MM' is no parameter or input"):
        system.write_ssp(fmus, tmp_path / "a.ssp", ice={**system.ICE, "ice.MM": 1.0})
    with pytest.raises(ValueError, match="'contact.force' is no parameter or input"):
        system.write_ssp(fmus, tmp_path / "b.ssp", ice={**system.ICE, "contact.force": 1.0})
    monkeypatch.setattr("iceimpact.fmi.ssp.ICE_COMPONENT", "ice")  # (the writer's module)
    with pytest.raises(ValueError, match="the component's name begins 'ice.M'"):
        system.write_ssp(fmus, tmp_path / "c.ssp")


# The masters ----------------------------------------------------------------------------------
@pytest.mark.parametrize("master", MASTERS)
def test_each_master_runs_the_scene_of_the_ssp(master, runs, ssp, reference, fmus):
    """Same grid, same contact, the FMPy Jacobi loop's displacement within the master's
    tolerance; while the scene with IceImpact's default structure.model = 1 is 5 % away."""
    result = run(runs, ssp, master)
    n = round(system.T_END / system.STEP)
    assert len(result["x"]) == len(result["time"]) == n + 1
    assert np.max(np.abs(result["time"] - np.arange(n + 1) * system.STEP)) < 1e-12
    assert result["count"] == reference["count"] >= 3  # contact happens, as often
    assert np.count_nonzero(result["force"]) == np.count_nonzero(reference["force"]) > 0
    error = system.relative_error(result, reference)
    assert error <= TOLERANCE[master], error
    if TOLERANCE[master] == 0.0:
        assert np.array_equal(result["force"], reference["force"])
    if "counts" in result:
        assert np.array_equal(result["counts"], reference["counts"])


def test_the_default_structure_model_gives_another_run(fmus, reference):
    """What the agreement above tells apart: the same loop with structure.model = 1 (IceImpact's
    built-in structure, the scene a master that lost the binding would run) is 5 % off."""
    other = system.fmpy_master(fmus, system.T_END, system.STEP, "jacobi",
                               ice={**system.ICE, "structure.model": 1})
    assert system.relative_error(other, reference) > 1e-2


def test_fmpy_needs_the_parameter_set(ssp, reference):
    """FMPy's simulate_ssp applies no inline binding: without the SSP's .ssv it runs the FMUs'
    defaults (linear drag, a 1600 kg floe...), far from the scene; hence the file."""
    from fmpy.ssp.simulation import simulate_ssp

    rows = simulate_ssp(str(ssp), stop_time=system.T_END, step_size=system.STEP)
    x = np.r_[0.0, rows[f"{system.STRUCTURE_COMPONENT}.x"]][:len(reference["x"])]
    assert system.relative_error({"x": x}, reference) > 0.5
    assert rows[f"{system.ICE_COMPONENT}.contact.count"][-1] != reference["count"]


@pytest.mark.parametrize("master", ["OMSimulator CLI", "OMSimulator API"])
def test_omsimulator_applied_every_binding(master, runs, ssp):
    """OMSimulator records the parameters as the FMU has them. The command line applies every
    binding itself; the Python API mangles the two names with a part 'model' (its instance path
    is model.root.floe), which omsimulator_api_run sets itself after instantiate()."""
    result = run(runs, ssp, master)
    for name, value in system.bindings()[system.ICE_COMPONENT].items():
        if name != "flow.u":  # an input: recorded as a time series, not as a parameter
            assert result["parameters"][name] == value, name
    assert result["parameters"]["structure.model"] == 2
    if master == "OMSimulator API":
        assert list(result["deferred"]) == ["drag.model", "structure.model"]


def test_omsimulator_cli_and_api_give_the_same_run(runs, ssp):
    """One engine, one master, one grid: the same numbers to the bit (the .mat result file
    keeps every digit; the CSV would keep 12)."""
    cli, api = run(runs, ssp, "OMSimulator CLI"), run(runs, ssp, "OMSimulator API")
    assert np.array_equal(cli["x"], api["x"]) and np.array_equal(cli["force"], api["force"])


def test_libcosim_loads_the_system_built_by_hand(runs, ssp, fmus):
    """from_ssp_file(path) with the SSP's step equals libcosimpy_run (the system built through
    libcosimpy's API) to the bit: the same integer-nanosecond clock and bindings."""
    _need("libcosimpy")
    by_hand = system.in_subprocess("libcosimpy_run", fmus, system.T_END, system.STEP)
    assert np.array_equal(run(runs, ssp, "libcosim from_ssp_file")["x"], by_hand["x"])
