"""The FMU side of the project, independent of the FMI library that hosts it (but for
:mod:`.slave_base`).

- :mod:`.lifecycle`: the FMI life cycle every FMU follows (:class:`~.lifecycle.FmuLifecycle`);
- :mod:`.adapter`: what each FMI call does to one IceImpact.fmu instance
  (:class:`~.adapter.FmuModel`);
- :mod:`.state_codec`: the serialized FMU state's layout (:class:`~.state_codec.StateCodec`);
- :mod:`.state`: IceImpact.fmu's state record, validated field by field;
- :mod:`.slave_base`: the PythonFMU slave of every FMU (:class:`~.slave_base.FmuSlave`);
- :mod:`.pythonfmu_fixes`: work-arounds for defects of PythonFMU 0.7.0's native library;
- :mod:`.ssp`: the system file of IceImpact.fmu coupled to ModalStructure.fmu (IceOnStructure.ssp).

The slaves ``fmu_src/IceImpact.py`` and ``fmu_src/ModalStructure.py`` only name their contract
and model class.
"""
