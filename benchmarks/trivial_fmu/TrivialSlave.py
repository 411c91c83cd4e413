"""TrivialSlave: a PythonFMU slave with IceImpact's input and outputs that does no work.

The floor for any PythonFMU FMU: ``benchmarks/fmu_overhead.py`` steps and records it exactly like
IceImpact.fmu, so the difference between the two is the cost of the model core.
"""

from __future__ import annotations

from typing import Any

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real

# IceImpact's outputs: name, type (registered the same way, read through getters).
OUTPUTS = (
    ("structure.x", Real), ("structure.v", Real), ("ice.z", Real), ("ice.v", Real),
    ("contact.gap", Real), ("contact.impulse", Real), ("contact.force", Real),
    ("contact.count", Integer), ("contact.active", Boolean), ("contact.t_last", Real),
)


class TrivialSlave(Fmi2Slave):
    """Same input and outputs as IceImpact; do_step returns at once."""

    author = "IceImpact contributors"
    description = "Reference FMU for overhead measurements: IceImpact's interface, no model"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._flow_u = 0.1
        self._values = {name: (False if kind is Boolean else 0 if kind is Integer else 0.0)
                        for name, kind in OUTPUTS}
        self.register_variable(Real("flow.u", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous,
                                    getter=lambda: self._flow_u, setter=self._set_flow),
                               nested=False)
        for name, kind in OUTPUTS:
            variability = (Fmi2Variability.continuous if kind is Real
                           else Fmi2Variability.discrete)
            self.register_variable(kind(name, causality=Fmi2Causality.output,
                                        variability=variability, initial=Fmi2Initial.exact,
                                        getter=self._getter(name)), nested=False)

    def _getter(self, name: str):
        return lambda: self._values[name]

    def _set_flow(self, value: float) -> None:
        self._flow_u = value

    def do_step(self, current_time: float, step_size: float) -> bool:
        return True
