"""What engineers compute from runs: impact statistics (``impacts.py``), design loads (extremes,
damage-equivalent loads: ``loads.py``) and spectra and lock-in (``analysis.py``). Each reads a
run's arrays; none imports the solvers. ``analysis`` uses ``loads`` and ``impacts``; ``loads``
uses ``impacts``; nothing goes the other way. ``seasons.py`` (load-case tables, lifetime DELs)
is the exception that runs: it drives the sweep engine and combines ``loads``' cycles.
"""
