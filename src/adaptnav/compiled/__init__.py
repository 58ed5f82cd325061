"""The Numba kernels of the hot paths: IMU-rate propagation
(:mod:`~adaptnav.compiled.propagation`) and the measurement epoch
(:mod:`~adaptnav.compiled.update`). Each has a readable NumPy twin
(:mod:`adaptnav.engine.propagation`, the models and sensors, and
``tests/helpers/engine_reference.py``) that the tests hold it equal to."""
