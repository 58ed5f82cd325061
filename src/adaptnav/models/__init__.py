"""Navigation models over :mod:`adaptnav.core`: the IMU noise specification
(:mod:`~adaptnav.models.imu_noise`), the strapdown mechanization and nominal state
(:mod:`~adaptnav.models.strapdown`) and the 15-state error model
(:mod:`~adaptnav.models.errorstate`)."""
