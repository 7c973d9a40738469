"""The EKF localizer of the design notes, on filterpy's ``ExtendedKalmanFilter``.

State x = [x, y, θ] (east, north [m], heading counter-clockwise from east [rad]) and its covariance P;
prediction from cmd_vel or odometry, updates from GPS, IMU yaw, range-bearing to known landmarks and
ranges to known beacons, χ² gating with a lockout guard, multi-rate and delayed input.

Modules:

* :mod:`.filter` — :class:`EKFLocalizer` and :class:`EKFLocalizerParams`: the models, prediction,
  updates and gating (the equations are stated there), and timed input in any arrival order;
* :mod:`.history` — the lagged-data history: snapshots, rewind and replay of delayed input;
* :mod:`.diagnostics` — the record of NIS values, rejections and recoveries;
* :mod:`.run` — ``EKFLocalizer.run(sequence)``: one pose per event of a :class:`Sequence`.
"""

from .diagnostics import SENSORS, Diagnostics
from .filter import KINDS, EKFLocalizer, EKFLocalizerParams, compass_to_yaw
from .run import run_sequence

EKFLocalizer.run = run_sequence  # bound here, so that filter.py does not import its runner (run.py imports filter.py)

__all__ = ["EKFLocalizer", "EKFLocalizerParams", "compass_to_yaw", "Diagnostics", "KINDS", "SENSORS"]
