"""The network inside a filter: an error-state EKF after TLIO that integrates the raw IMU and takes a
window model's mean velocity as its measurement (``docs/filter.md``).

- ``state``: parameters (``FilterConfig``), the nominal state and the rotation algebra;
- ``ekf``: propagation, clones, the velocity update and its Jacobians;
- ``session``: the one stepping core, a stream of samples through the filter (``FilterSession``);
- ``run``: one recording through the filter with a model in the loop (``filter_prediction``);
- ``holes``: one filter per stretch between a recording's held holes;
- ``settle``: offline, a second pass from where the first settled (biases, tilt carried back);
- ``levelled``: the model re-read on the filter's orientation (what ``filter=ekf`` answers);
- ``choice``: ``filter=none|ekf`` at every door;
- ``consistency``: tilt error, NEES and NIS bounds.
"""

from ftin.filter.ekf import ErrorStateEkf
from ftin.filter.run import FilterRun, NetworkVelocity, filter_prediction, run_filter
from ftin.filter.state import FilterConfig

__all__ = ["ErrorStateEkf", "FilterConfig", "FilterRun", "NetworkVelocity", "filter_prediction", "run_filter"]
