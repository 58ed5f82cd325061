"""Reading runs back: metrics against the truth (:mod:`~adaptnav.analysis.evaluate`), the
filter comparison (:mod:`~adaptnav.analysis.compare`), the DVL dead-reckoning floor
(:mod:`~adaptnav.analysis.floor`), calibration estimates against the simulator's truth
(:mod:`~adaptnav.analysis.calibration`) and a DVL fitted to a reference
(:mod:`~adaptnav.analysis.dvl_fit`). Imports the api and below, never the figures."""
