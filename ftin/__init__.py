"""FTIN Studio: inertial odometry with the Frequency-Time Integration Network and its baselines."""

__version__ = "0.1.0"
