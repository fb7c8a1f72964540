"""Pedestrian IMU simulator with exact ground truth, and the app's shipped sample sequences.

``simulate(SimConfig(carry="pocket", duration_s=90, seed=3))`` returns an ``ImuSequence`` whose
gyro and accelerometer are the exact derivatives of its ground-truth pose (plus, unless
``noise=None``, a phone-like sensor error model). See ``ftin.sim.trajectory`` for how consistency
is guaranteed and ``ftin.sim.samples`` for the shipped CSV samples.
"""

from ftin.sim.config import CarryMode, ImuNoise, SimConfig
from ftin.sim.imu import STANDARD_GRAVITY_M_S2
from ftin.sim.simulator import simulate, simulate_motion

__all__ = ["STANDARD_GRAVITY_M_S2", "CarryMode", "ImuNoise", "SimConfig", "simulate", "simulate_motion"]
