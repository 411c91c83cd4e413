"""The FMU side of IceImpact, independent of the FMI library that hosts it.

- :mod:`.adapter`: what each FMI call does to one instance (:class:`~.adapter.FmuModel`);
- :mod:`.state`: the serialized FMU state, a versioned layout validated field by field;
- :mod:`.pythonfmu_fixes`: work-arounds for defects of PythonFMU 0.7.0's native library.

The slave ``fmu_src/IceImpact.py`` only maps PythonFMU's calls onto these.
"""
