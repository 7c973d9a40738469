"""The EKF localizer on cmd_vel + GPS + IMU topics of a bag written from ``sim:localization``: the same estimate as on
the simulator's Sequence (the bag round trip: stamps to the nanosecond, GPS through geodetic coordinates)."""

from __future__ import annotations

import numpy as np
from bags import GPS_ORIGIN, localization_bag

from slamarena import datasets
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def test_localizer_on_a_bag_equals_the_localizer_on_the_simulation(tmp_path):
    import slamarena

    sim = datasets.load("sim:localization", duration=20.0, seed=4)
    localization_bag(sim, tmp_path / "loc.bag")
    bag = datasets.load(f"bag:{tmp_path / 'loc.bag'}", truth_topic="/truth", gps_origin=GPS_ORIGIN)
    assert bag.meta["motion_source"].startswith("/cmd_vel") and bag.meta["gps_origin"]["lat_deg"] == GPS_ORIGIN[0]
    first_fix = datasets.load(f"bag:{tmp_path / 'loc.bag'}").gps.xy  # the default origin: the first fix
    np.testing.assert_allclose(first_fix - first_fix[0], sim.gps.xy - sim.gps.xy[0], atol=1e-3)
    assert np.all(first_fix[0] == 0.0)
    np.testing.assert_allclose(bag.gps.xy, sim.gps.xy, atol=1e-6)  # geodetic and back
    np.testing.assert_allclose(bag.motion.v, sim.motion.v)
    np.testing.assert_allclose(bag.motion.dt, sim.motion.dt, atol=1e-8)
    np.testing.assert_allclose(bag.noise.gps_cov, sim.noise.gps_cov)
    assert bag.noise.yaw_var == sim.noise.yaw_var
    on_sim = slamarena.create("ekf_localizer").run(sim)
    on_bag = slamarena.create("ekf_localizer").run(bag)
    # stamps a float ulp apart in the simulation (a GPS fix at 0.2 s, a command at 10 × 0.02 s) are one nanosecond
    # stamp in the bag: compare the posterior after the last event of each bag stamp
    last = np.searchsorted(on_sim.t, on_bag.t + 1e-8, side="right") - 1
    np.testing.assert_allclose(on_sim.t[last], on_bag.t, atol=1e-8)
    np.testing.assert_allclose(on_bag.poses, on_sim.poses[last], atol=1e-5)
    a_bag, _ = ate(on_bag, reference_of(bag), ATEParams(align="none"))  # the truth topic scores it
    assert a_bag["rmse"] < 0.05
