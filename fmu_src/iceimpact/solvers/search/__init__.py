"""The searches of the exact method: where a signal first crosses zero, never skipping a root.

- :mod:`.rootfind`: :class:`~.rootfind.RootSearch`, the no-miss root search of any signal given
  with bounds on its curvature and jerk (a flight's gap, a sticking phase's contact force); its
  time resolution is :data:`iceimpact.limits.TIME_RESOLUTION`.
- :mod:`.step`: one step of that search on plain floats (the stretches proven root-free or
  monotone, the descent, the bracketed Newton iteration), the rules RootSearch and the flight
  search both make their steps with.
- :mod:`.flight_search`: its common steps for a flight (the free structure, the ice under
  either drag law) as one function on the constants of the physics' closed forms
  (``Oscillator.under_constants``, the drags' ``flight_constants`` and ``law_constants``),
  making its steps with :mod:`.step`'s functions, compiled by numba where installed; the same
  steps to the bit.
- :mod:`.taylor`: the quadratic-drag sticking phase's Taylor steps (no closed form), with the
  bound on the rest of each step that lets the root search cross it; the runs of steps and the
  states on them compiled by numba where installed.
- :mod:`.taylor_series`: one Taylor step's kernels: the recurrence, the step-size rule and the
  proof that a step holds no root.
- :mod:`.dragged`: the structure under the quadratic Morison drag in a flight, its Taylor steps
  made in arrays for the compiled search and march.

Whether and how the kernels are compiled (numba installed, ``ICEIMPACT_PURE`` unset; no
fastmath: the pure functions' floats) is :mod:`iceimpact.compiled`'s.
"""
