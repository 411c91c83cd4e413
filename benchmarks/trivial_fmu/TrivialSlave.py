"""TrivialSlave: a PythonFMU slave with IceImpact's inputs and outputs that does no work.

The floor for any PythonFMU FMU: ``benchmarks/fmu_overhead.py`` steps and records it exactly like
IceImpact.fmu, so the difference between the two is the cost of the model core.

It reads and sets its variables the way a PythonFMU slave does by default: it registers a getter
(and for the inputs a setter) per variable and keeps PythonFMU's own ``get_real``,
``get_integer``, ``get_boolean`` and ``set_*``, which call one getter per value reference after a
type test. IceImpact's slave replaces those with batch calls over value-reference tables
(``iceimpact.fmi.slave_base``); this one does not, on purpose: the yardstick is a do-nothing
PythonFMU slave as PythonFMU makes it (``benchmarks/fmu_overhead.py`` checks it overrides none of
them).
"""

from __future__ import annotations

from typing import Any

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real

# IceImpact's inputs and outputs: name, type (registered the same way, read through getters);
# benchmarks/fmu_overhead.py checks them against the contract.
INPUTS = ("flow.u", "structure.x_in", "structure.v_in", "structure.a_in")
OUTPUTS = (
    ("structure.x", Real), ("structure.v", Real), ("ice.z", Real), ("ice.v", Real),
    ("contact.gap", Real), ("contact.impulse", Real), ("contact.force", Real),
    ("contact.count", Integer), ("contact.active", Boolean), ("contact.t_last", Real),
    ("contact.penetration", Real), ("structure.force", Real), ("coupling.force", Real),
)


class TrivialSlave(Fmi2Slave):
    """Same inputs and outputs as IceImpact; do_step returns at once."""

    author = "IceImpact contributors"
    description = "Reference FMU for overhead measurements: IceImpact's interface, no model"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._inputs = {name: 0.1 if name == "flow.u" else 0.0 for name in INPUTS}
        self._values = {name: (False if kind is Boolean else 0 if kind is Integer else 0.0)
                        for name, kind in OUTPUTS}
        for name in INPUTS:
            self.register_variable(Real(name, causality=Fmi2Causality.input,
                                        variability=Fmi2Variability.continuous,
                                        getter=self._input_getter(name),
                                        setter=self._setter(name)), nested=False)
        for name, kind in OUTPUTS:
            variability = (Fmi2Variability.continuous if kind is Real
                           else Fmi2Variability.discrete)
            self.register_variable(kind(name, causality=Fmi2Causality.output,
                                        variability=variability, initial=Fmi2Initial.exact,
                                        getter=self._getter(name)), nested=False)

    def _getter(self, name: str):
        return lambda: self._values[name]

    def _input_getter(self, name: str):
        return lambda: self._inputs[name]

    def _setter(self, name: str):
        def set_input(value: float) -> None:
            self._inputs[name] = value
        return set_input

    def do_step(self, current_time: float, step_size: float) -> bool:
        return True
