"""Latitude / longitude back from the local plane (``ftin.data.geo``), a predicted walk anchored on GPS
(``ftin.metrics.gps_anchor``) and the recording's start on the phone's clock (``ftin.data.epoch``),
on the real GPS track of the shared phyphox walk (~460 s, ~230 m across)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftin.data import epoch
from ftin.data.geo import lat_lon
from ftin.data.location import GpsTrack, local_plane, phyphox_track
from ftin.data.types import Trajectory
from ftin.metrics.gps import compare_gps
from ftin.metrics.gps_anchor import NoAnchorError, anchor_on_gps

PHYPHOX_WALK = Path("phone") / "phyphox" / "walk-no-gyroscope"


@pytest.fixture(scope="module")
def track(shared_data: Path) -> GpsTrack:
    path = shared_data / PHYPHOX_WALK / "Location.csv"
    if not path.is_file():
        pytest.skip(f"no phyphox GPS at {path}")
    found = phyphox_track(path.read_bytes(), "Location.csv", 0.0)
    assert found is not None
    return found


def test_lat_lon_inverts_the_local_plane(track: GpsTrack) -> None:
    lat, lon = lat_lon(track.local_plane(), track.lat_deg[0], track.lon_deg[0])
    assert np.abs(lat - track.lat_deg).max() < 1e-10 and np.abs(lon - track.lon_deg).max() < 1e-10
    # and tens of kilometres away, far beyond a walk, still to a tenth of a millimetre
    far = np.array([[30_000.0, -40_000.0], [-25_000.0, 50_000.0]])
    lat, lon = lat_lon(far, 65.0, 25.5)
    assert local_plane(np.r_[65.0, lat], np.r_[25.5, lon])[1:] == pytest.approx(far, abs=1e-4)


def turned_prediction(
    track: GpsTrack, turn_deg: float, shift_m=(7.0, -3.0), scale: float = 1.0
) -> Trajectory:
    """The GPS walk as a model in another frame would predict it: turned by ``-turn_deg``, shifted,
    sampled at the fix times (inside the track, the first fix included)."""
    t, keep = np.unique(track.t_s, return_index=True)
    en = track.local_plane()[keep]
    a = np.radians(-turn_deg)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    xy = scale * (en - en[0]) @ R.T + shift_m
    return Trajectory(t, np.column_stack([xy, np.zeros(len(t))]))


@pytest.mark.parametrize("fit", ["start", "walk"])
def test_a_prediction_in_another_frame_lands_on_its_gps(track: GpsTrack, fit: str) -> None:
    path = anchor_on_gps(turned_prediction(track, 40.0), track, fit)
    assert path.heading_deg == pytest.approx(40.0, abs=1e-6)
    assert path.distance_rms_m < 1e-6 and path.fixes_used == len(np.unique(track.t_s))
    t, keep = np.unique(track.t_s, return_index=True)
    assert np.abs(path.lat_deg - track.lat_deg[keep]).max() < 1e-9
    assert np.abs(path.lon_deg - track.lon_deg[keep]).max() < 1e-9


def test_the_start_fit_shows_drift_that_the_walk_fit_spreads(track: GpsTrack) -> None:
    short = turned_prediction(track, 40.0, scale=0.8)  # a model that walks 20 % short
    start, walk = anchor_on_gps(short, track, "start"), anchor_on_gps(short, track, "walk")
    assert start.lat_deg[0] == pytest.approx(track.lat_deg[0], abs=1e-9)  # pinned at the first fix
    assert walk.distance_rms_m < start.distance_rms_m  # the best overlay, never a rescaled path
    # the start fit is the page's and the scene's: its distance to the fixes is their GPS figure
    assert start.distance_rms_m == pytest.approx(compare_gps(short, track).distance_rms_m, rel=1e-9)
    assert walk.distance_rms_m > 5.0  # 20 % of a ~230 m walk cannot vanish without a scale
    assert "first GPS fix" in start.text and "no scale" in walk.text


def test_gps_outside_the_recording_anchors_nothing(track: GpsTrack) -> None:
    later = Trajectory(np.array([1000.0, 1001.0, 1002.0]), np.zeros((3, 3)))  # after the last fix
    with pytest.raises(NoAnchorError, match="0 fix"):
        anchor_on_gps(later, track)
    with pytest.raises(NoAnchorError, match="no GPS track"):
        anchor_on_gps(later, None)


TIME_CSV = (
    '"event","experiment time","system time","system time text"\n'
    '"START",0.000000000E0,1.694245631599E9,"2023-09-09 09:47:11.599 UTC+02:00"\n'
    '"PAUSE",1.216540000E1,1.694245643764E9,"2023-09-09 09:47:23.764 UTC+02:00"\n'
    '"START",1.216540000E1,1.694245700000E9,"2023-09-09 09:48:20.000 UTC+02:00"\n'
)


def test_phyphox_time_csv_maps_the_experiment_clock_to_the_epoch() -> None:
    extra = {"time.csv": TIME_CSV.encode()}
    assert epoch.phyphox_start_epoch_s(extra, 0.5) == pytest.approx(1694245631.599 + 0.5)
    # after the pause, the second START maps the clock
    assert epoch.phyphox_start_epoch_s(extra, 13.0) == pytest.approx(1694245700.0 + 13.0 - 12.1654)
    assert epoch.phyphox_start_epoch_s({}, 0.0) is None
    assert epoch.phyphox_start_epoch_s({"time.csv": b"event\nSTART\n"}, 0.0) is None


def test_a_start_that_is_no_date_is_dropped() -> None:
    assert epoch.start_meta(12.5) == {}  # seconds since a phone's boot, not the epoch
    assert epoch.start_meta(1.7e9) == {epoch.START_KEY: 1.7e9}
    assert epoch.start_epoch_s({"dataset": "euroc", "t0_ns": 1403636579758555392}) == pytest.approx(
        1403636579.7585554
    )
    assert epoch.start_epoch_s({"dataset": "ridi"}) is None
