"""The constructed stale-first-estimate case (the test tests/estimators/test_ekf_slam.py::
test_a_stale_first_estimate_locks_fej_out_and_is_set_again, here for every linearisation and with and without the anchor
test; research/notebook/2026-11-28-landmark-real-data.md). Prints, per filter, the largest and final error of the
robot's position relative to landmark B over the orbit, the rows the gate refused and the points set again.

    python research/scripts/landmark_real_data_stale_anchor.py
"""

import numpy as np

from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.models import observe

A, B = np.array([2.0, 0.0]), np.array([4.0, 4.0])


def run(jac, anchor, turn_err=0.5):
    ekf = EKFSLAM(
        jacobians=jac,
        anchor_confidence=anchor,
        twist_cov=[0.01, 0.5],
        range_bearing_cov=[0.01, 0.0004],
        known_confidence=0.999,
    )
    true = np.zeros(3)

    def move(v, w, dt=0.1, err=0.0):
        nonlocal true
        true = true + np.array([v * dt * np.cos(true[2]), v * dt * np.sin(true[2]), w * dt])
        ekf.predict([v, w + err], dt)

    def see(*ids):
        ekf.update(np.column_stack([observe(true, np.array([A, B])[list(ids)]), ids]))

    see(0)
    for _ in range(10):
        move(0.0, np.pi / 4, err=turn_err)
    for _ in range(40):
        move(1.0, 0.0)
    see(1)
    for _ in range(10):
        move(0.0, -np.pi / 2)
    for _ in range(5):
        see(0, 1)
    gated, err = 0, []
    for k in range(300):
        move(0.5, 0.0 if k == 0 else 0.5 / 1.5)
        see(1)
        gated += ekf.assoc_log[-1][0] == 2
        err.append(np.linalg.norm((ekf.x[:2] - ekf.x[5:7]) - (true[:2] - B)))
    return np.array(err), gated, ekf.anchors_reset


def main():
    for turn_err in (0.3, 0.5, 0.8):
        for jac in ("standard", "fej", "oc"):
            for anchor in (None, 0.99999):
                e, g, r = run(jac, anchor, turn_err)
                print(
                    f"odometry error {turn_err} rad/s {jac:8s} anchor {anchor}: relative error max {e.max():.2f} "
                    f"final {e[-1]:.2f} m, gated {g}, points set again {r}"
                )


if __name__ == "__main__":
    main()
