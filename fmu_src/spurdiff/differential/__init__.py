"""The differential: its parameters (:mod:`.params`) and mass properties (:mod:`.inertia`), statics
and the locking law from the pin loads (:mod:`.statics`, :mod:`.locking`), the models behind one
interface (:mod:`.model_base`): the rigid level (:mod:`.rigid`, its pin-load law :mod:`.rigid_pinload`
and compiled kernel :mod:`.rigid_kernel`), the compliant and contact mesh levels (:mod:`.mesh`), and
the half-shafts around any of them (:mod:`.shafts`, :mod:`.shaft_params`, :mod:`.shaft_solver`),
and the watches on a run (:mod:`.watches`: load capacity, overspeed).

May import: :mod:`spurdiff.gears` and the core. Never the vehicle or the FMI layer.
"""
