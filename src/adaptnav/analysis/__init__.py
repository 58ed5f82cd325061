"""Reading runs back: metrics against the truth (:mod:`~adaptnav.analysis.evaluate`), the
filter comparison (:mod:`~adaptnav.analysis.compare`) and the DVL dead-reckoning floor
(:mod:`~adaptnav.analysis.floor`). Imports the api and below, never the figures."""
