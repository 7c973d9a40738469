"""The ACFR Car Park reader on the staged files (values checked by hand against ``scipy.io.loadmat`` printouts of the
MAT-files and SOURCE.md), the calibration it states (the GPS antenna at the laser, the beams counter-clockwise from the
right), the beacons extracted from its raw scans, and malformed files."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged
from scipy.io import loadmat, savemat

from slamarena.datasets import DataFormatError
from slamarena.datasets.errors import DataWarning
from slamarena.datasets.formats.carpark import read_files
from slamarena.datasets.geometry import compose, interpolate_poses
from slamarena.mapping.landmark_extraction import extract

pytestmark = pytest.mark.realdata

L, H, A, B = 2.83, 0.76, 3.78, 0.50


@pytest.fixture(scope="module")
def carpark():
    return load_staged("carpark")


def test_first_and_last_rows(carpark):
    m, s, gt = carpark.motion, carpark.scans, carpark.ground_truth
    # Time_VS[0, :2] = [45.024, 45.049]: the first row precedes the first GPS fix (45.047) and is dropped
    assert (
        len(m) == 5000
        and np.isclose(m.t[0], 45.049, rtol=0, atol=1e-12)
        and carpark.meta["motion_rows_before_first_fix"] == 1
    )
    # Velocity[0, 1] = 2.0120826, Steering[0, 1] = 0.27641376: the axle's twist by the Ackerman model
    v = 2.0120826 / (1 - np.tan(0.27641376) * H / L)
    assert np.isclose(m.v[0], v, rtol=1e-12) and np.isclose(m.omega[0], v * np.tan(0.27641376) / L, rtol=1e-12)
    assert np.isclose(m.t[-1], 170.024, rtol=0, atol=1e-12) and np.isclose(
        m.v[-1], 2.3474297 / (1 - np.tan(0.22010764) * H / L)
    )
    assert np.allclose(m.dt[:-1], 0.025, atol=1e-9)
    # TimeLaser[0, 0] = 45.103; Laser[0, [0, 1, 180, 360]] = [0.84, 0.85, 81.91, 11.6]; Intensity[0, [19, 20, 334]] =
    # [8192, 32768, 8192] (every other beam of scan 0: 0)
    assert len(s) == 586 and np.isclose(s.t[0], 45.103 - 0.015)
    assert np.array_equal(s.ranges[0, [0, 1, 180, 360]], [0.84, 0.85, 81.91, 11.6]) and s.max_range == 80.0
    assert np.flatnonzero(s.intensities[0]).tolist() == [19, 20, 334]
    assert s.intensities[0, [19, 20, 334]].tolist() == [1.0, 4.0, 1.0]
    assert np.allclose(s.angles[[0, 180, 360]], [-np.pi / 2, 0.0, np.pi / 2]) and np.allclose(s.mount, [A, B, -0.014])
    # TimeGPS[0, 0] = 45.047, GPSLon/GPSLat[0, 0] = 5.10475776, 4.20435697: the laser's position, the axle behind it
    assert len(gt) == 626 and np.isclose(gt.t[0], 45.047, rtol=0, atol=1e-12)
    laser = compose(gt.poses[0], [A, B, 0.0])
    assert np.allclose(laser[:2], [5.10475776, 4.20435697], atol=1e-8)
    # estbeac rows 1 and 15
    assert np.allclose(carpark.landmarks.xy[[0, 14]], [[2.89529811, -4.03525397], [5.71608243, 16.43149405]])
    assert np.array_equal(carpark.landmarks.ids, np.arange(15))
    assert np.allclose(carpark.start_pose, interpolate_poses(gt.t, gt.poses, np.array([45.049]))[0])


def test_the_gps_antenna_is_at_the_laser(carpark):
    """The GPS speed is the laser point's (Ackerman model: |(v − ω b, ω a)|), not the axle's: over the run the two
    agree to 0.3 % (the axle's speed is 12 % below the GPS's: the laser point swings wide in the turns)."""
    m, gt = carpark.motion, carpark.ground_truth
    laser = compose(gt.poses, [A, B, 0.0])
    t_mid = 0.5 * (gt.t[1:] + gt.t[:-1])
    gps_speed = np.hypot(*np.diff(laser[:, :2], axis=0).T) / np.diff(gt.t)
    v, w = np.interp(t_mid, m.t, m.v), np.interp(t_mid, m.t, m.omega)
    laser_speed = np.hypot(v - w * B, w * A)
    assert abs(np.sum(laser_speed * gps_speed) / np.sum(laser_speed**2) - 1) < 0.01
    assert np.sum(v * gps_speed) / np.sum(v**2) > 1.1
    assert np.sqrt(np.mean((laser_speed - gps_speed) ** 2)) < 0.06


def test_beacons_extracted_from_the_raw_scans_land_on_the_survey(carpark):
    """Real scans: the bright, narrow segments seen from the GPS poses lie on the 15 surveyed beacons (each of them
    seen), 97 % within 0.3 m; beams taken clockwise they do not."""
    det = extract(carpark.scans, features="beacons")
    gt = carpark.ground_truth
    inside = (det.t >= gt.t[0]) & (det.t <= gt.t[-1])
    sensor = compose(interpolate_poses(gt.t, gt.poses, det.t[inside]), carpark.scans.mount)

    def on_survey(bearing):
        angle = sensor[:, 2] + bearing
        xy = sensor[:, :2] + det.range[inside, None] * np.column_stack([np.cos(angle), np.sin(angle)])
        d = np.hypot(xy[:, 0, None] - carpark.landmarks.xy[:, 0], xy[:, 1, None] - carpark.landmarks.xy[:, 1])
        return d.min(axis=1), d.argmin(axis=1)

    distance, nearest = on_survey(det.bearing[inside])
    assert len(det) > 850 and np.mean(distance < 0.3) > 0.97
    assert set(nearest[distance < 0.3]) == set(range(15))
    assert np.mean(on_survey(-det.bearing[inside])[0] < 0.3) < 0.3


def _write(tmp_path, **changes):
    """The staged files copied with ``changes`` (variable → array) to data_set.mat."""
    from checks import staged

    data = {k: v for k, v in loadmat(staged("acfr_carpark/data_set.mat")).items() if not k.startswith("__")}
    data.update(changes)
    savemat(tmp_path / "data_set.mat", data)
    return tmp_path / "data_set.mat", staged("acfr_carpark/beac_juan3.mat")


def test_malformed_files_name_the_file_and_element(tmp_path):
    from checks import staged

    t = loadmat(staged("acfr_carpark/data_set.mat"))["Time_VS"].copy()
    t[0, 6] = np.nan
    with pytest.raises(DataFormatError, match=r"data_set.mat:7: expected finite values in 'Time_VS'"):
        read_files(*_write(tmp_path, Time_VS=t))
    t = loadmat(staged("acfr_carpark/data_set.mat"))["TimeLaser"].copy()
    t[0, 10] = t[0, 8]
    with pytest.raises(DataFormatError, match=r"data_set.mat:11: expected non-decreasing 'TimeLaser'"):
        read_files(*_write(tmp_path, TimeLaser=t))
    with pytest.raises(DataFormatError, match=r"variable 'Intensity' of shape \(586, 361\)"):
        read_files(*_write(tmp_path, Intensity=np.zeros((586, 360))))
    with pytest.raises(DataFormatError, match=r"variable 'Velocity' of shape 1 × 5001"):
        read_files(*_write(tmp_path, Velocity=np.zeros((1, 5000))))
    (tmp_path / "broken.mat").write_bytes(b"not a MAT-file")
    with pytest.raises(DataFormatError, match="broken.mat: expected a MATLAB v5 MAT-file"):
        read_files(tmp_path / "broken.mat", staged("acfr_carpark/beac_juan3.mat"))


def test_absurd_speeds_are_dropped_and_counted(tmp_path):
    from checks import staged

    v = loadmat(staged("acfr_carpark/data_set.mat"))["Velocity"].copy()
    v[0, [100, 200]] = [1e300, -40.0]
    with pytest.warns(DataWarning, match=r"data_set.mat:101: 2 speed/steering element\(s\) dropped"):
        seq = read_files(*_write(tmp_path, Velocity=v))
    assert seq.meta["dropped_lines"]["out_of_range"]["data_set.mat"] == [101, 201] and len(seq.motion) == 4998
