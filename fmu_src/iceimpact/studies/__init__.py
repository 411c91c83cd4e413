"""What engineers compute from runs: impact statistics (``impacts.py``), design loads (extremes,
damage-equivalent loads: ``loads.py``), spectra and lock-in (``analysis.py``) and OpenFAST text
output (``outfiles.py``). Each reads a run's arrays; none imports the solvers, the sweep engine
or :mod:`iceimpact.seasons` (which runs load-case tables on the sweep engine and combines
``loads``' cycles: both use this package, never the reverse). ``analysis`` uses ``loads`` and
``impacts``; ``loads`` uses ``impacts``; nothing goes the other way.
"""
