"""IceImpact: vibrations of a flexible structure struck repeatedly by flow-driven ice.

The model of "Vibrations due to Flow-Driven Repeated Impacts": a free ice mass pushed by a current
(Morison drag, linearised or quadratic) onto a damped single-degree-of-freedom structure; impacts
conserve momentum with a coefficient of restitution.

    >>> from iceimpact import Scene, run
    >>> result = run(Scene(), t_end=10.0)          # the article's Figure 2 scene
    >>> result.impacts["t"][:3]                    # impact times, s
"""
from .contract import VERSION
from .errors import ParameterError, SolverError, StateError
from .scene import PARAMETERS, Scene, load_scene
from .simulator import Result, Simulator, StepReport, run
from .solvers.base import Impact

__all__ = ["PARAMETERS", "Impact", "ParameterError", "Result", "Scene", "Simulator",
           "SolverError", "StateError", "StepReport", "load_scene", "run"]
__version__ = VERSION
