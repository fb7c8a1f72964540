"""The network inside a filter: an error-state EKF after TLIO that integrates the raw IMU and takes a
window model's mean velocity as its measurement (``docs/filter.md``).

- ``state``: parameters (``FilterConfig``), the nominal state and the rotation algebra;
- ``ekf``: propagation, clones, the velocity update and its Jacobians;
- ``run``: one recording through the filter with a model in the loop (``filter_prediction``);
- ``consistency``: tilt error, NEES and NIS bounds.
"""

from ftin.filter.ekf import ErrorStateEkf
from ftin.filter.run import FilterRun, NetworkVelocity, filter_prediction, run_filter
from ftin.filter.state import FilterConfig

__all__ = ["ErrorStateEkf", "FilterConfig", "FilterRun", "NetworkVelocity", "filter_prediction", "run_filter"]
