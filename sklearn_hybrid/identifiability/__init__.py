"""Is theta identified?  Profiles, the bootstrap and intervals of network-free models.

- :func:`profile_theta`: for each parameter of a hybrid fit, the loss with the
  parameter held at each value of a grid and everything else (the other
  parameters and the network) re-trained: an interval, and a verdict
  (identified, practically or structurally non-identifiable).
- :func:`bootstrap_theta`: fits on resampled samples with new seeds: the spread
  of theta between data sets and training runs.
- :func:`science_intervals`: intervals of a model without a network (the
  closed loop's ``science_only``), robust to errors correlated along a trajectory.
"""

from ..plotting import plot_profile
from .bootstrap import ThetaBootstrap, bootstrap_theta
from .profile import ADVICE, IDENTIFIED, PRACTICAL, STRUCTURAL, UNSETTLED, ThetaProfile, profile_theta
from .science_only import ScienceIntervals, science_intervals

__all__ = ["profile_theta", "ThetaProfile", "plot_profile", "bootstrap_theta", "ThetaBootstrap",
           "science_intervals", "ScienceIntervals", "IDENTIFIED", "PRACTICAL", "STRUCTURAL", "UNSETTLED",
           "ADVICE"]
