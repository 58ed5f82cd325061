"""Simulation: exact IMU signals of analytically defined motions (the simulator's core).

:mod:`adaptnav.sim.kinematics` turns a motion given as closed-form functions of time (geodetic
position with two derivatives, ZYX Euler angles with one) into the true navigation states and
the error-free IMU rates and increments that a perfect strapdown IMU would output.
"""

from __future__ import annotations

from adaptnav.sim.kinematics import (
    Kinematics,
    Motion,
    imu_increments,
    imu_rates,
    stationary,
    true_kinematics,
    true_states,
    turn_with_waves,
)

__all__ = [
    "Kinematics",
    "Motion",
    "imu_increments",
    "imu_rates",
    "stationary",
    "true_kinematics",
    "true_states",
    "turn_with_waves",
]
