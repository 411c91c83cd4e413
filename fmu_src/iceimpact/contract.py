"""The FMI contract of IceImpact.fmu: every variable, its unit, range, start value and meaning.

This table is the one home of the FMU's interface (the documentation's page of FMU
variables is generated from it; a test checks that the built modelDescription.xml agrees with
it). Everything else draws from it:

- :mod:`iceimpact.scene` validates parameters against the ranges here and takes its defaults
  from the start values here;
- the slave (``fmu_src/IceImpact.py``) registers exactly these variables, with these
  causalities and variabilities;
- ``build_fmu.py`` writes units, min/max, descriptions, the default experiment and what each
  output depends on (ModelStructure) from it;
- the CLI resolves ``--set`` / ``--vary`` names against it.

Adding a variable: one row here, plus the physics that uses it (a :class:`~iceimpact.Scene`
field for a parameter or input, a :class:`~iceimpact.StepReport` field for an output); an output
names the knowns it depends on (``initial_depends_on``, ``depends_on``), which
tests/fmu/test_model_structure.py measures.
This module imports nothing from the package: it is the bottom layer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: Version of the model core and of the FMU (pyproject.toml reads it from here).
VERSION = "0.3.0"

MODEL_IDENTIFIER = "IceImpact"
AUTHOR = "IceImpact contributors"
LICENSE = "MIT"
DESCRIPTION = ("Flow-driven repeated ice impacts on a flexible structure: a damped SDOF structure "
               "struck by an ice floe pushed by the current")


@dataclass(frozen=True)
class DefaultExperiment:
    """The FMU's DefaultExperiment: the article's Figure 2 run (400 s) at 1 ms steps."""

    start_time: float = 0.0   # s
    stop_time: float = 400.0  # s
    step_size: float = 1e-3   # s


DEFAULT_EXPERIMENT = DefaultExperiment()

# Causalities and variabilities, as FMI 2.0 spells them.
PARAMETER, INPUT, OUTPUT = "parameter", "input", "output"
FIXED, TUNABLE, CONTINUOUS, DISCRETE = "fixed", "tunable", "continuous", "discrete"
# How a known enters an output (FMI 2.0 dependenciesKind): with no particular structure; FIXED
# ("fixed") is a factor of fixed parameters, p * known.
DEPENDENT = "dependent"

# Enumerations of the Integer parameters (named so that the physics never compares with 1, 2, 3).
LINEAR_DRAG, QUADRATIC_DRAG = 1, 2                        # drag.model
METHOD_EXACT, METHOD_FIXED_STEP, METHOD_ODE = 1, 2, 3     # solver.method
DETECTION_WINDOW, DETECTION_SIGN = 1, 2                   # solver.detection
STRUCTURE_BUILTIN, STRUCTURE_EXTERNAL, STRUCTURE_MODAL = 1, 2, 3  # structure.model
LOAD_HELD, LOAD_LINEAR = 0, 1                             # structure.load_order
SCHEME_GAUSS_SEIDEL, SCHEME_JACOBI = 1, 2                 # coupling.scheme

#: Most modes of the built-in modal structure (structure.model = 3): FMI 2.0 has no arrays, so
#: the FMU has structure.mode1.* to structure.mode5.*, of which the first structure.modes are used.
MAX_MODES = 5
# The built-in SDOF structure's defaults (m, c, k below) as mode 1's f, zeta and m.
_M, _C, _K = 1600.0, 200.0, 1.0e6
MODE_F = math.sqrt(_K / _M) / (2.0 * math.pi)  # Hz
MODE_ZETA = _C / (2.0 * math.sqrt(_K * _M))    # 1

#: Default of solver.max_impacts, and the largest FMI 2.0 Integer (a 32-bit fmi2Integer).
MAX_IMPACTS = 100_000
#: Default of solver.max_evaluations: about 20 s of CPU at method 3's measured ~5 us an
#: evaluation (its right-hand side and scipy's step around it)
MAX_EVALUATIONS = 4_000_000
INT32_MAX = 2**31 - 1
#: Default of solver.chatter_fraction: a bounce shorter than this fraction of the structure's
#: natural period ends an elastic chatter (docs/explanation/accuracy.md, "The chatter threshold").
CHATTER_FRACTION = 1e-2


@dataclass(frozen=True)
class Variable:
    """One FMI variable.

    ``field`` is the :class:`~iceimpact.Scene` field of a parameter or input, the
    :class:`~iceimpact.StepReport` field of an output. ``minimum``/``maximum`` bound the allowed
    values (``min_exclusive``/``max_exclusive`` make a bound strict); ``allowed`` is the range as
    a reader sees it in error messages and docs.

    An output's dependencies are its rows of modelDescription.xml's ModelStructure:
    ``depends_on`` names the inputs it depends on directly within a communication step (an
    fmi2Set of the input changes what fmi2Get returns before the next fmi2DoStep), each with
    its FMI ``dependenciesKind`` (``Outputs``); ``initial_depends_on`` names the knowns of
    Initialization Mode (parameters and inputs) its value after fmi2ExitInitializationMode
    depends on (``InitialUnknowns``). Empty: it depends on none.
    """

    name: str
    field: str
    causality: str
    kind: type                 # float (Real), int (Integer) or bool (Boolean)
    unit: str                  # SI, as in modelDescription.xml; "" for Integer and Boolean
    description: str
    start: float | int | bool | None = None
    allowed: str = "finite"
    minimum: float | None = None
    maximum: float | None = None
    min_exclusive: bool = False
    max_exclusive: bool = False
    variability: str = FIXED
    choices: dict[int, str] = field(default_factory=dict)  # Integer enumerations
    depends_on: dict[str, str] = field(default_factory=dict)  # input name -> dependenciesKind
    initial_depends_on: tuple[str, ...] = ()

    @property
    def tunable(self) -> bool:
        return self.variability == TUNABLE

    def in_range(self, value: float) -> bool:
        """True if the finite number ``value`` lies within [minimum, maximum] (strict where
        marked); the allowed set of an Integer enumeration is its ``choices``."""
        if self.choices:
            return value in self.choices
        if self.minimum is not None and (value < self.minimum
                                         or (self.min_exclusive and value == self.minimum)):
            return False
        if self.maximum is not None and (value > self.maximum
                                         or (self.max_exclusive and value == self.maximum)):
            return False
        return True


def _real(name: str, unit: str, description: str, start: float, allowed: str = "finite",
          **kw) -> Variable:
    return Variable(name, name.replace(".", "_"), PARAMETER, float, unit, description, start,
                    allowed, **kw)


def _enum(name: str, description: str, start: int, choices: dict[int, str]) -> Variable:
    keys = [str(k) for k in choices]
    allowed = (", ".join(keys[:-1]) + " or " + keys[-1] + " ("
               + "; ".join(f"{k} = {v}" for k, v in choices.items()) + ")")
    return Variable(name, name.replace(".", "_"), PARAMETER, int, "", description, start,
                    allowed, minimum=min(choices), maximum=max(choices), choices=choices)


_POSITIVE = {"allowed": "> 0", "minimum": 0.0, "min_exclusive": True}
_NON_NEGATIVE = {"allowed": ">= 0", "minimum": 0.0}


def mode_rows(k: int) -> tuple[tuple[str, str, str, float, dict], ...]:
    """Mode k's parameters as (field, unit, meaning, start, range) rows, the one table of both
    the modal structure's (``structure.mode<k>.*``) and ModalStructure.fmu's (``mode<k>.*``):
    the defaults are the built-in SDOF structure as mode 1 and modes 2 to 5 alike but with
    phi = 0, so that a mode switched on without values of its own does not move the contact
    point."""
    return (
        ("f", "Hz", "natural frequency (undamped)", MODE_F, _POSITIVE),
        ("zeta", "1", "damping ratio (1 = critical; any value >= 0)", MODE_ZETA, _NON_NEGATIVE),
        ("m", "kg", "modal mass", _M, _POSITIVE),
        ("phi", "1", "mode-shape value at the contact point (x = sum phi q; the contact force F "
         "drives the mode with phi F)", 1.0 if k == 1 else 0.0, {}),
        ("q0", "m", "initial modal displacement", 0.0, {}),
        ("v0", "m/s", "initial modal velocity", 0.0, {}),
    )


def _mode_parameters(k: int) -> tuple[Variable, ...]:
    """Mode k's parameters of the modal structure (structure.model = 3): :func:`mode_rows`."""
    return tuple(_real(f"structure.mode{k}.{field}", unit, f"modal structure, mode {k}: {meaning}",
                       start, **limits) for field, unit, meaning, start, limits in mode_rows(k))


#: Parameters, in the order of their value references (append new ones at the end).
PARAMETERS: tuple[Variable, ...] = (
    _real("structure.m", "kg", "structure mass", 1600.0, **_POSITIVE),
    _real("structure.c", "N.s/m", "structure viscous damping", 200.0, **_NON_NEGATIVE),
    _real("structure.k", "N/m", "structure stiffness", 1.0e6, **_POSITIVE),
    _real("structure.x0", "m", "initial structure displacement", 0.0),
    _real("structure.v0", "m/s", "initial structure velocity", 0.0),
    _real("ice.M", "kg", "ice (free) mass", 1600.0, **_POSITIVE),
    _real("ice.A", "m2", "ice drag area", 1.0, **_POSITIVE),
    _real("ice.Cd", "1", "ice drag coefficient", 1.0, **_NON_NEGATIVE),
    _real("ice.z0", "m", "initial ice displacement (upstream of the structure)", -0.01,
          allowed="finite and <= structure.x0"),
    _real("ice.v0", "m/s", "initial ice velocity", 0.01),
    _real("fluid.rho", "kg/m3", "fluid density", 999.0, **_POSITIVE),
    _real("impact.e", "1", "coefficient of restitution (eq. 13)", 1.0, allowed="0 <= e <= 1",
          minimum=0.0, maximum=1.0, variability=TUNABLE),
    _enum("drag.model", "drag law: 1 = linearised (eq. 4), 2 = quadratic (eq. 3)", LINEAR_DRAG,
          {LINEAR_DRAG: "linearised", QUADRATIC_DRAG: "quadratic"}),
    _real("drag.v_lin", "m/s", "linearisation speed of the drag (eq. 5)", 0.1, **_POSITIVE),
    _enum("solver.method", "1 = exact event-driven, 2 = fixed-step (the article's scheme), "
          "3 = ODE (scipy)", METHOD_EXACT,
          {METHOD_EXACT: "exact", METHOD_FIXED_STEP: "fixed-step", METHOD_ODE: "ODE"}),
    # dt >= 1 ns: a smaller grid needs over 1e9 points per simulated second (minutes of work per
    # second) and its grid times lose their precision
    _real("solver.dt", "s", "internal step of method 2", 1.0e-4, allowed=">= 1e-9",
          minimum=1e-9),
    # rtol >= 1e-13: scipy raises anything below 100 machine epsilons to 2.2e-14 anyway, and
    # atol = 1e-3 rtol must stay above the rounding of the states
    _real("solver.rtol", "1", "relative tolerance of method 3", 1.0e-8,
          allowed="1e-13 <= rtol < 1", minimum=1e-13, maximum=1.0, max_exclusive=True),
    # the sign test by default: the article's window misses every impact where the structure
    # is at rest (its width is the structure's speed times the step; docs/explanation/accuracy.md)
    _enum("solver.detection", "impact test of method 2: 2 = sign change of the gap (the "
          "default); 1 = the article's tolerance window of eq. 26, only to reproduce the "
          "article: it misses every impact at a structure at rest (zero width), so the ice "
          "passes through it", DETECTION_SIGN,
          {DETECTION_WINDOW: "window", DETECTION_SIGN: "sign"}),
    _enum("solver.ode_method", "integrator of method 3: 1 = RK45, 2 = DOP853, 3 = LSODA, "
          "4 = Radau", 2, {1: "RK45", 2: "DOP853", 3: "LSODA", 4: "Radau"}),
    _enum("structure.model", "structure: 1 = built-in SDOF (structure.m, c, k, x0, v0), "
          "2 = external, in another FMU (inputs structure.x_in, v_in, a_in; structure.m is its "
          "effective mass at the contact point; c, x0, v0 are ignored), 3 = built-in modal "
          "structure (structure.modes and structure.mode<k>.*; structure.m, c, k, x0, v0 are "
          "ignored)", STRUCTURE_BUILTIN,
          {STRUCTURE_BUILTIN: "built-in SDOF", STRUCTURE_EXTERNAL: "external",
           STRUCTURE_MODAL: "modal"}),
    _enum("coupling.scheme", "external structure (structure.model = 2): how the master passes "
          "contact.force to the structure. 1 = Gauss-Seidel, ice first (the structure feels a "
          "step's force over that same step, before its x, v reach the ice again); 2 = Jacobi "
          "(both step from the same values, the structure feels a step's force over the next "
          "step: ECOS, libcosim). Ignored with the built-in structure", SCHEME_GAUSS_SEIDEL,
          {SCHEME_GAUSS_SEIDEL: "Gauss-Seidel, ice first", SCHEME_JACOBI: "Jacobi"}),
    # Morison loads on the structure (docs/explanation/morison.md): each term is off while its
    # product is 0
    _real("structure.Ca", "1", "Morison added-mass coefficient of the structure: added mass "
          "fluid.rho Ca V moves with it (0 = off)", 0.0, **_NON_NEGATIVE),
    _real("structure.V", "m3", "displaced volume of the structure (added mass fluid.rho Ca V)",
          0.0, **_NON_NEGATIVE),
    _real("structure.Cd", "1", "Morison drag coefficient of the structure: drag "
          "fluid.rho Cd A |u - v| (u - v) / 2 under drag.model (0 = off)", 0.0, **_NON_NEGATIVE),
    _real("structure.A", "m2", "projected area of the structure facing the flow (drag)", 0.0,
          **_NON_NEGATIVE),
    # a step's latency bound: at the costliest measured ~0.3 ms an impact (a stick-part cycle at
    # a stiff structure, docs/explanation/robustness/stiff-structures.md) 1e5 impacts are ~30 s of
    # CPU; the article's scenes
    # make at most a few thousand impacts a simulated second
    Variable("solver.max_impacts", "solver_max_impacts", PARAMETER, int, "",
             "most impacts in one communication step: a step that needs more is refused "
             "(fmi2Discard, the state stays as before it); shorter steps go on", MAX_IMPACTS,
             allowed=f"1 <= max_impacts <= {INT32_MAX}", minimum=1,
             maximum=INT32_MAX),
    # method 3's latency bound: its work per simulated second is bounded by the rules of
    # limits.py, but not a step's length (an FMU host cannot interrupt a step)
    Variable("solver.max_evaluations", "solver_max_evaluations", PARAMETER, int, "",
             "most right-hand-side evaluations of method 3's integrator in one communication "
             "step: a step whose integration needs more is refused (fmi2Discard, the state "
             "stays as before it); shorter steps go on. Methods 1 and 2 do not integrate",
             MAX_EVALUATIONS, allowed=f"1 <= max_evaluations <= {INT32_MAX}", minimum=1,
             maximum=INT32_MAX),
    # chatter threshold of methods 1 and 3 (solvers/contact_rules.py). Above 0.5 a "chatter"
    # bounce would last half a period, motion the structure resolves; below 1e-6 the chatter
    # time of a stiff structure falls under the exact search's time resolution
    # (limits.omega_limit scales with it) and an elastic chatter costs up to
    # omega_n / (2 pi fraction) impacts per simulated second (1.6e5 omega_n at 1e-6)
    _real("solver.chatter_fraction", "1", "chatter threshold of methods 1 and 3: with "
          "impact.e = 1 a bounce of the ice pressed on the structure that would last less than "
          "this fraction of the structure's natural period 2 pi / omega_n ends the bouncing "
          "with one plastic impact (a smaller fraction resolves more of the chatter, at more "
          "impacts); with impact.e < 1 it marks the bounces from which a Zeno sequence is "
          "counted against its budget (docs/explanation/accuracy.md). Method 2 does not use it",
          CHATTER_FRACTION, allowed="1e-6 <= chatter_fraction <= 0.5", minimum=1e-6,
          maximum=0.5),
    # the modal structure (structure.model = 3; docs/explanation/modes.md): the same four
    # numbers per mode as ModalStructure.fmu's, and its initial state
    Variable("structure.modes", "structure_modes", PARAMETER, int, "",
             f"modes of the modal structure (structure.model = 3): structure.mode1.* to "
             f"structure.mode<modes>.* are used, 1 to {MAX_MODES}", 1,
             allowed=f"1 <= modes <= {MAX_MODES}", minimum=1, maximum=MAX_MODES),
    *(v for k in range(1, MAX_MODES + 1) for v in _mode_parameters(k)),
    # a load held over a step is first order in the step; continued at its last rate, second
    # order for a smooth load (docs/explanation/modes.md#loads-in-modal-states-out)
    _enum("structure.load_order", "modal structure (structure.model = 3): how each input "
          "structure.mode<k>.load goes over a communication step (the FMU's inputs only). "
          "0 = held; 1 = continued at its rate between the last two communication points "
          "(for a smooth load from another FMU: an error second order in the step instead of "
          "first; the first step holds)", LOAD_HELD,
          {LOAD_HELD: "held", LOAD_LINEAR: "linear"}),
)

#: Inputs, held constant within a communication step (zero-order hold).
INPUTS: tuple[Variable, ...] = (
    Variable("flow.u", "flow_u", INPUT, float, "m/s",
             "flow speed, positive towards the structure", 0.1, variability=CONTINUOUS),
    Variable("structure.x_in", "structure_x_in", INPUT, float, "m",
             "external structure (structure.model = 2): displacement of the contact point at "
             "the start of the communication step", 0.0, variability=CONTINUOUS),
    Variable("structure.v_in", "structure_v_in", INPUT, float, "m/s",
             "external structure (structure.model = 2): velocity of the contact point at the "
             "start of the communication step", 0.0, variability=CONTINUOUS),
    Variable("structure.a_in", "structure_a_in", INPUT, float, "m/s2",
             "external structure (structure.model = 2), optional: acceleration of the contact "
             "point at the start of the step under the last contact.force, for a second-order "
             "extrapolation (0 = not given)", 0.0, variability=CONTINUOUS),
)
INPUTS += tuple(
    Variable(f"structure.mode{k}.load", f"structure_mode{k}_load", INPUT, float, "N",
             f"modal structure (structure.model = 3), mode {k}: generalized force from the rest "
             "of the system (wave, wind or rotor loads projected on the mode), held over a "
             "communication step", 0.0, variability=CONTINUOUS)
    for k in range(1, MAX_MODES + 1))
FLOW_INPUT = INPUTS[0]
#: The external structure's inputs (structure.model = 2), in the order x, v, a.
STRUCTURE_INPUTS: tuple[Variable, ...] = INPUTS[1:4]
#: The modal structure's load inputs (structure.model = 3), mode 1 to MAX_MODES.
MODE_LOAD_INPUTS: tuple[Variable, ...] = INPUTS[4:4 + MAX_MODES]


def _out(name: str, field: str, kind: type, unit: str, description: str,
         variability: str = CONTINUOUS, **kw) -> Variable:
    if kind is not float:
        variability = DISCRETE
    return Variable(name, field, OUTPUT, kind, unit, description, variability=variability,
                    allowed="", **kw)


#: The knowns of the contact rules at the start time: whether bodies at zero gap impact, stick
#: or part there (contact.count, contact.active, contact.t_last after initialization) is
#: decided from the velocities and accelerations of the whole scene and the flow speed, down to
#: the rounding level of its speeds; declared in full rather than as the few a scene exercises.
START_CONTACT = tuple(p.name for p in PARAMETERS) + (FLOW_INPUT.name,)
# The initial structure is structure.x0, v0 built in, the inputs' start values external.
# The modal structure's contact point starts at sum phi q0, moving at sum phi v0.
_MODAL = ("structure.modes",)
_X0 = ("structure.model", "structure.x0") + _MODAL + tuple(
    f"structure.mode{k}.{f}" for k in range(1, MAX_MODES + 1) for f in ("phi", "q0"))
_V0 = ("structure.model", "structure.v0") + _MODAL + tuple(
    f"structure.mode{k}.{f}" for k in range(1, MAX_MODES + 1) for f in ("phi", "v0"))

#: Outputs: values at the end of the last communication step. Appended ones keep the value
#: references of the older ones. Stored by fmi2DoStep, none depends on an input within a step
#: (no depends_on); after initialization they are the scene's start, built from the parameters
#: and flow.u at fmi2ExitInitializationMode (structure.x_in, v_in, a_in are read by the first
#: step only).
OUTPUTS: tuple[Variable, ...] = (
    _out("structure.x", "x", float, "m", "structure displacement", initial_depends_on=_X0),
    _out("structure.v", "v", float, "m/s", "structure velocity", initial_depends_on=_V0),
    _out("ice.z", "z", float, "m", "ice displacement", initial_depends_on=("ice.z0",)),
    _out("ice.v", "w", float, "m/s", "ice velocity", initial_depends_on=("ice.v0",)),
    _out("contact.gap", "gap", float, "m",
         "gap x - z between structure and ice, never negative", minimum=0.0,
         initial_depends_on=_X0 + ("ice.z0",)),
    _out("contact.impulse", "impulse", float, "N.s",
         "impulse delivered to the structure during the last communication step "
         "(impacts plus sticking contact)"),
    _out("contact.force", "force", float, "N",
         "mean contact force over the last communication step: contact.impulse / step size"),
    _out("contact.count", "impact_count", int, "", "impacts since the start", minimum=0,
         initial_depends_on=START_CONTACT),
    _out("contact.active", "sticking", bool, "", "true while the bodies stick together",
         initial_depends_on=START_CONTACT),
    _out("contact.t_last", "t_last", float, "s",
         "time of the latest impact (-1 before the first)", variability=DISCRETE,
         initial_depends_on=START_CONTACT),
    # a valid built-in scene starts with ice.z0 <= structure.x0; an external one from x = 0
    _out("contact.penetration", "penetration", float, "m",
         "distance the ice is past the structure (z - x > 0), else 0: the fixed-step method's "
         "grid (solver.method = 2), or the ODE method's integration error (3, of the order of "
         "its absolute tolerance, 1e-3 solver.rtol m); always 0 with the exact method",
         minimum=0.0, initial_depends_on=("structure.model", "ice.z0")),
    _out("structure.force", "spring_force", float, "N",
         "spring force k x of the structure: the base shear of the SDOF idealisation, the load "
         "a design check takes (docs/explanation/design-loads.md). With the modal structure "
         "(structure.model = 3) k_c x, k_c = 1 / sum(phi_k^2 / (m_k (2 pi f_k)^2)) the static "
         "stiffness at the contact point: the quasi-static equivalent load there (one mode with "
         "phi = 1: the SDOF's k x), without the modes' own dynamic amplification of member "
         "forces, which follow from structure.mode<k>.q and the modal stresses of the FE model "
         "(docs/explanation/modes.md). 0 with an external structure (2), whose internal forces "
         "live in the other FMU",
         # k_c x0: the modal structure's stiffness at the contact point takes each f and m too
         initial_depends_on=_X0 + ("structure.k",) + tuple(
             f"structure.mode{k}.{f}" for k in range(1, MAX_MODES + 1) for f in ("f", "m"))),
    _out("coupling.force", "coupling_force", float, "N",
         "external structure (structure.model = 2): the force for the master to hold on the "
         "structure over its next step. contact.force, except with a Jacobi master "
         "(coupling.scheme = 2) while the ice rides on the structure: the contact force "
         "predicted for the next step, the structure feeling it one step late (what it "
         "predicts more than delivered is given back at the separation, so the impulses add "
         "up to the contact impulses)"),
    *(_out(f"structure.mode{k}.{quantity}", f"mode{k}_{quantity}", float, unit,
           f"modal structure (structure.model = 3), mode {k}: modal {meaning} (0 with another "
           "structure or a mode not used)",
           # mode 1 is used whatever structure.modes (>= 1) is; mode k > 1 from modes = k on
           initial_depends_on=("structure.model",) + (_MODAL if k > 1 else ())
           + (f"structure.mode{k}.{start}",))
      for k in range(1, MAX_MODES + 1)
      for quantity, unit, meaning, start in (("q", "m", "displacement", "q0"),
                                             ("v", "m/s", "velocity", "v0"))),
)

#: Every variable, in value-reference order per type as the slave registers them.
VARIABLES: tuple[Variable, ...] = PARAMETERS + INPUTS + OUTPUTS
BY_NAME: dict[str, Variable] = {v.name: v for v in VARIABLES}
#: The names a scene holds (parameters and input start values), for scene files and the CLI.
SCENE_VARIABLES: dict[str, Variable] = {v.name: v for v in PARAMETERS + INPUTS}


def number_text(value: float | int) -> str:
    """A number as modelDescription.xml and the docs write it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if float(value).is_integer() and abs(value) < 1e15:
        return repr(int(value))
    return repr(float(value)) if math.isfinite(value) else str(value)


def markdown_table(variables: tuple[Variable, ...] = VARIABLES, *, fold: str = "",
                   fold_note: str = "") -> str:
    """The variables as a Markdown table (the documentation's page of FMU variables is made
    from it at every build).

    ``fold`` names a prefix of numbered groups, such as ``"mode"`` for ``mode1.f``, ``mode2.f``,
    ...: the rows of groups 2 and above are then summarised in one row after group 1's, which
    says how their start values differ from group 1's; ``fold_note`` is its meaning column.
    """
    kinds = {float: "Real", int: "Integer", bool: "Boolean"}
    groups = {v.name: _group(v.name, fold) for v in variables}
    rows = ["| name | causality | type | unit | start | allowed | meaning |",
            "|---|---|---|---|---|---|---|"]
    last_of_first = max((i for i, v in enumerate(variables) if groups[v.name] == 1), default=-1)
    for i, v in enumerate(variables):
        if groups[v.name] > 1:
            continue
        causality = v.causality + (" (tunable)" if v.tunable else "")
        start = "" if v.start is None else number_text(v.start)
        rows.append(f"| `{v.name}` | {causality} | {kinds[v.kind]} | {v.unit or '–'} | {start} | "
                    f"{v.allowed} | {v.description} |")
        if i == last_of_first:
            rows.append(_folded_row(variables, groups, fold, fold_note, kinds))
    return "\n".join(rows) + "\n"


def _group(name: str, prefix: str) -> int:
    """The group number of ``<prefix><n>.<field>`` (``mode2.f``: 2), else 0."""
    head, dot, _ = name.partition(".")
    number = head[len(prefix):]
    return int(number) if prefix and dot and head.startswith(prefix) and number.isdigit() else 0


def _folded_row(variables: tuple[Variable, ...], groups: dict[str, int], prefix: str, note: str,
                kinds: dict[type, str]) -> str:
    folded = [v for v in variables if groups[v.name] > 1]
    first = {v.name.partition(".")[2]: v for v in variables if groups[v.name] == 1}
    differ: dict[str, str] = {}
    for v in folded:
        field = v.name.partition(".")[2]
        if v.start != first[field].start:
            differ.setdefault(field, number_text(v.start))
    start = f"as {prefix} 1" + ("" if not differ else ", but " + ", ".join(
        f"{field} = {text}" for field, text in differ.items()))
    causality = " / ".join(dict.fromkeys(v.causality for v in folded))
    kind = " / ".join(dict.fromkeys(kinds[v.kind] for v in folded))
    last = max(groups.values())
    return (f"| `{prefix}2.*` … `{prefix}{last}.*` | {causality} | {kind} | | {start} | "
            f"as {prefix} 1 | {note} |")
