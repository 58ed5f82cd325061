"""Estimation over the models: the Kalman update (:mod:`~adaptnav.estimation.kalman`), the
gate and guard (:mod:`~adaptnav.estimation.gate`), the divergence guard
(:mod:`~adaptnav.estimation.health`), the measurement-noise strategies and Q adaptation
(:mod:`adaptnav.estimation.noise`) and the filter settings (:mod:`~adaptnav.estimation.settings`).
Nothing here knows time ordering; that is the engine's."""
