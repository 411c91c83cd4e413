"""The searches of the exact method: where a signal first crosses zero, never skipping a root.

- :mod:`.rootfind`: :class:`~.rootfind.RootSearch`, the no-miss root search of any signal given
  with bounds on its curvature and jerk (a flight's gap, a sticking phase's contact force); its
  time resolution is :data:`iceimpact.limits.TIME_RESOLUTION`.
- :mod:`.flight_search`: its common steps for a flight (an under-damped structure, the ice under
  either drag law) written out as one function on the constants of the physics' closed forms
  (``Oscillator.under_constants``, the drags' ``flight_constants`` and ``law_constants``),
  compiled by numba where installed; the same steps to the bit.
- :mod:`.taylor`: the quadratic-drag sticking phase's Taylor steps (no closed form), with the
  bound on the rest of each step that lets the root search cross it; its recurrence and Horner's
  rule compiled by numba where installed.

Whether and how the kernels are compiled (numba installed, ``ICEIMPACT_PURE`` unset; no
fastmath: the pure functions' floats) is :mod:`iceimpact.compiled`'s.
"""
