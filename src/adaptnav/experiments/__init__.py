"""Studies over many runs: seeded sweeps and Monte Carlo (:mod:`~adaptnav.experiments.sweep`)
and the simulated-fault benchmark (:mod:`~adaptnav.experiments.faultbench`)."""
