"""Applications that turn other formats into mission folders: the Snapir AUV (A-KIT) segments
(:mod:`~adaptnav.importers.akit`) and the RTKLIB car drive (:mod:`~adaptnav.importers.rtklib`)."""
