"""Studies over many runs: seeded sweeps and Monte Carlo, and the simulated-fault benchmark.

* :mod:`~adaptnav.experiments.spec`: what to run (:class:`~adaptnav.experiments.spec.RunSpec`,
  the paper's q, process-noise and Monte Carlo sweeps);
* :mod:`~adaptnav.experiments.cache`: simulated missions, alignments and finished runs on disk;
* :mod:`~adaptnav.experiments.runner`: running specs, cached and in parallel
  (:func:`~adaptnav.experiments.runner.run_sweep`);
* :mod:`~adaptnav.experiments.cluster`: where the runs go, a local or remote dask cluster
  (docs/scale-out.md);
* :mod:`~adaptnav.experiments.stats`: the sweep's table and statistics over it;
* :mod:`~adaptnav.experiments.figures`: the sweeps' figures (the paper's Figs. 4 and 6);
* :mod:`~adaptnav.experiments.faultbench`: the simulated-fault benchmark.
"""
