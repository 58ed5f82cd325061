"""The Python API: load a mission, run a filter, get a :class:`~adaptnav.api.results.Result`.

``adaptnav.api.run(mission, kind)`` (:mod:`~adaptnav.api.runner`) is what the command line runs;
:class:`~adaptnav.api.stream.Stream` is the same filter fed one reading at a time
(docs/streaming.md); :mod:`~adaptnav.api.results` is a run's data model and folder format,
:mod:`~adaptnav.api.oracle` the oracle baseline's true noise, :mod:`~adaptnav.api.outdir` the
atomic output folders.
"""

from adaptnav.api.runner import OFF_REASON, FilterError, initial_state, run
from adaptnav.api.stream import Stream, replay

__all__ = ["OFF_REASON", "FilterError", "Stream", "initial_state", "replay", "run"]
