"""The only layer that knows time ordering: the multirate batch engine
(:mod:`~adaptnav.engine.batch`), the channels a filter kind runs (:mod:`~adaptnav.engine.channels`),
whole-interval propagation (:mod:`~adaptnav.engine.propagation`) and the static alignment
(:mod:`~adaptnav.engine.align`)."""
