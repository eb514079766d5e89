"""The vehicle around the differential: the tyre's slip law (:mod:`.tyre`), the wheel with its
half-shaft and load (:mod:`.wheel`, :mod:`.wheel_params`), and the planar car (:mod:`.car`, its
parameters :mod:`.car_params` and equations of motion :mod:`.car_rates`).

May import: the core only (the vehicle meets the differential through the FMUs' variables, not
through Python imports). Never the FMI layer.
"""
