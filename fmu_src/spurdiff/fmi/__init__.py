"""The FMI layer: the variable records (:mod:`.variables`), their binding to model parameters
(:mod:`.binding`), the three FMU declarations (:mod:`.differential_fmu`, :mod:`.wheel_fmu`,
:mod:`.vehicle_fmu`) and the adapter that makes an FMU class of a declaration (:mod:`.adapter`).

May import: every other package of spurdiff (it sits on top); nothing imports it but the harness.
"""
