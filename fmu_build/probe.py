"""The import probe of a standalone FMU's build: prints the modules a slave imports, as JSON.

    python -P probe.py <fmu>/resources <slave class> <scenes as JSON>

Run in a fresh process by :func:`fmu_build.standalone.imported_modules` on an extracted FMU: it
imports the slave the way PythonFMU does (the module named in resources/slavemodule.txt), drives
it through every scene (parameters set before initialization, inputs set before every step),
reads every output, saves, serializes and restores its state, lets it refuse a state that is no
state, and prints the sorted names of ``sys.modules``. A scene that fails still counts: its
imports happened. It imports nothing beyond what it measures needs (``-P``: this folder stays off
the module path), so that every module it prints is one the slave or the interpreter loaded.
"""
import importlib
import json
import sys
import xml.etree.ElementTree as ET

#: Communication step of the probe's runs, s.
STEP = 1e-3


def slave_variables(resources: str) -> dict:
    """name -> (value reference, FMI 2.0 type tag) of the FMU's variables."""
    described = ET.parse(resources + "/../modelDescription.xml").getroot()
    return {v.get("name"): (int(v.get("valueReference")), v[0].tag)
            for v in described.iter("ScalarVariable")}


def set_value(slave, variables: dict, name: str, value) -> None:
    """Set the variable ``name`` of ``slave`` through the setter of its type."""
    reference, tag = variables[name]
    getattr(slave, "set_" + tag.lower())([reference], [value])


def run(slave_class, resources: str, variables: dict, values: dict, steps: int = 300,
        inputs: tuple = ()) -> None:
    """One instance: ``values`` set before initialization, ``inputs`` before every one of
    ``steps`` steps; then every variable read, the state saved, serialized and restored, one more
    step, and the end."""
    slave = slave_class(instance_name="probe", resources=resources, visible=False)
    slave.setup_experiment(0.0, None, None)
    for name, value in values.items():
        set_value(slave, variables, name, value)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    for k in range(steps):
        for name, value in inputs:
            set_value(slave, variables, name, value)
        slave.do_step(k * STEP, STEP)
    for tag in ("Real", "Integer", "Boolean"):
        references = [reference for reference, t in variables.values() if t == tag]
        getattr(slave, "get_" + tag.lower())(references)
    state = slave._get_fmu_state()
    slave._set_fmu_state(slave_class._fmu_state_from_bytes(
        slave_class._fmu_state_to_bytes(state)))
    slave.do_step(steps * STEP, STEP)
    slave.terminate()


def main(resources: str, kind: str, scenes: list) -> list[str]:
    """The sorted names of ``sys.modules`` after the slave class ``kind`` of the FMU whose
    resources folder is ``resources`` ran every scene ``(parameters, inputs)``."""
    sys.path.insert(0, resources)  # the FMU's own modules, as PythonFMU imports them
    with open(resources + "/slavemodule.txt") as file:
        module = file.read().strip()
    slave_class = getattr(importlib.import_module(module), kind)
    variables = slave_variables(resources)
    for values, inputs in scenes:
        try:
            run(slave_class, resources, variables, values,
                inputs=tuple(tuple(i) for i in inputs))
        except Exception:  # a refused scene has imported what it needed all the same
            pass
    try:  # a state that is no state: refused
        slave_class._fmu_state_from_bytes(b"not a state")
    except Exception:
        pass
    return sorted(sys.modules)


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], sys.argv[2], json.loads(sys.argv[3]))))
