"""GPX and GeoJSON of a phone walk anchored on its GPS, and CSV / TUM on the phone's own clock
(``clock=epoch``), on the shared Sensor Logger export of a 20-step walk.

That export's own Location.csv is empty, so its GPS is written here from the prediction itself: the
predicted path turned by 35 degrees and placed at a known latitude / longitude. A right anchoring
then puts the exported path exactly on the fixes, which an off-by-a-turn, swapped-axis or
lon/lat-order bug cannot do.
"""

from __future__ import annotations

import datetime as dt
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from ftin.data.geo import lat_lon
from tests.app.routes.helpers import detail, upload
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.utils.gps import LAT0, LON0, sensorlogger_location_csv, twenty_steps_export

GPX = "{http://www.topografix.com/GPX/1/1}"
TURN_DEG = 35.0
RECORDING_EPOCH_MS = 1711795429936  # the export's Metadata.csv: "recording epoch time"


@pytest.fixture(scope="module")
def twenty_steps(shared_data: Path) -> Path:
    return twenty_steps_export(shared_data)


@pytest.fixture(scope="module")
def plain(client: TestClient, twenty_steps: Path) -> dict:
    """The walk uploaded without GPS (the export's own empty Location.csv left out)."""
    response = upload(client, sensorlogger_zip(twenty_steps, None), "walk.zip")
    assert response.status_code == 200, response.text
    return response.json()


@pytest.fixture(scope="module")
def start_epoch_s(client: TestClient, plain: dict) -> float:
    return client.get(f"/runs/{plain['run_id']}/metrics.json").json()["start_epoch_s"]


def fixes_from_prediction(plain: dict, start_epoch_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fix times (every second from the prediction's start, on its 0.5 s export grid) and the
    prediction there, turned by ``TURN_DEG`` and placed at (LAT0, LON0)."""
    traj = plain["trajectory"]
    t = np.asarray(traj["t"])
    fix_t = np.arange(t[0], t[-1], 1.0)
    xy = np.column_stack([np.interp(fix_t, t, traj[a]) for a in ("x", "y")])
    c, s = np.cos(np.radians(TURN_DEG)), np.sin(np.radians(TURN_DEG))
    east_north = (xy - xy[0]) @ np.array([[c, s], [-s, c]])  # rows turned counter-clockwise
    lat, lon = lat_lon(east_north, LAT0, LON0)
    return fix_t, lat, lon


@pytest.fixture(scope="module")
def with_gps(client: TestClient, twenty_steps: Path, plain: dict, start_epoch_s: float) -> dict:
    fix_t, lat, lon = fixes_from_prediction(plain, start_epoch_s)
    ns = np.round((start_epoch_s + fix_t) * 1e9).astype(np.int64)
    location = sensorlogger_location_csv(ns, fix_t, lat, lon, [4.0] * len(fix_t))
    response = upload(client, sensorlogger_zip(twenty_steps, location), "walk.zip")
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["trajectory"] == plain["trajectory"]  # GPS changes nothing in the prediction
    return body


def test_the_sensorlogger_export_knows_when_it_started(start_epoch_s: float) -> None:
    # the first sample comes a fraction of a second after the app's "recording epoch time"
    assert 0.0 <= start_epoch_s - RECORDING_EPOCH_MS / 1000 < 1.0


@pytest.mark.parametrize("fit", ["start", "walk"])
def test_the_gpx_puts_the_walk_on_its_gps_fixes(
    client: TestClient, with_gps: dict, plain, start_epoch_s, fit
) -> None:
    response = client.get(f"/runs/{with_gps['run_id']}/trajectory.gpx", params={"fit": fit})
    assert response.status_code == 200, response.text
    assert response.headers["content-type"].startswith("application/gpx+xml")
    assert response.headers["content-disposition"].endswith('_trajectory.gpx"')
    root = ET.fromstring(response.content)
    assert root.tag == f"{GPX}gpx" and root.get("version") == "1.1" and root.get("creator")
    # GPX 1.1 orders the children: metadata, then tracks; in metadata name, desc, ..., time
    assert [c.tag for c in root] == [f"{GPX}metadata", f"{GPX}trk", f"{GPX}trk"]
    assert [c.tag for c in root[0]] == [f"{GPX}name", f"{GPX}desc", f"{GPX}time"]
    predicted, gps = root.findall(f"{GPX}trk")
    assert "(predicted)" in predicted.findtext(f"{GPX}name") and gps.findtext(f"{GPX}name") == "GPS fixes"
    points = predicted.findall(f"{GPX}trkseg/{GPX}trkpt")
    lat = np.array([float(p.get("lat")) for p in points])
    lon = np.array([float(p.get("lon")) for p in points])
    times = [dt.datetime.fromisoformat(p.findtext(f"{GPX}time").replace("Z", "+00:00")) for p in points]
    assert all(len(p) == 1 and p[0].tag == f"{GPX}time" for p in points)
    t = np.array([stamp.timestamp() for stamp in times]) - start_epoch_s
    assert np.all(np.diff(t) > 0) and t[0] == pytest.approx(plain["trajectory"]["t"][0], abs=2e-3)
    assert np.diff(t)[:-1] == pytest.approx(0.5, abs=2e-3)  # a point every 0.5 s
    # at the fix times the exported path lies on the fixes (1e-7 degrees is 1 cm)
    fix_t, fix_lat, fix_lon = fixes_from_prediction(plain, start_epoch_s)
    north_m = (np.interp(fix_t, t, lat) - fix_lat) * 111_130
    east_m = (np.interp(fix_t, t, lon) - fix_lon) * 111_130 * np.cos(np.radians(LAT0))
    assert np.hypot(north_m, east_m).max() < 0.05
    assert len(gps.findall(f"{GPX}trkseg/{GPX}trkpt")) == len(fix_t)
    desc = predicted.findtext(f"{GPX}desc")
    assert (
        "first GPS fix" if fit == "start" else "every GPS fix"
    ) in desc and "median GPS accuracy 4 m" in desc


def test_the_geojson_is_longitude_first(client: TestClient, with_gps: dict, plain, start_epoch_s) -> None:
    response = client.get(f"/runs/{with_gps['run_id']}/trajectory.geojson")
    assert response.status_code == 200, response.text
    assert response.headers["content-type"].startswith("application/geo+json")
    body = response.json()
    assert body["type"] == "FeatureCollection"
    predicted, gps = body["features"]
    assert predicted["type"] == "Feature" and predicted["geometry"]["type"] == "LineString"
    coordinates = np.array(predicted["geometry"]["coordinates"])
    assert coordinates.shape[1] == 2
    assert np.abs(coordinates[:, 0] - LON0).max() < 1e-3 and np.abs(coordinates[:, 1] - LAT0).max() < 1e-3
    properties = predicted["properties"]
    assert properties["model"] == with_gps["model"] and properties["anchor"] == "start"
    assert len(properties["times"]) == len(properties["t_s"]) == len(coordinates)
    assert properties["times"][0].endswith("Z") and properties["start_time"].startswith("2024-03-30T10:43:5")
    fix_t, fix_lat, fix_lon = fixes_from_prediction(plain, start_epoch_s)
    assert gps["properties"]["kind"] == "gps" and gps["properties"]["accuracy_m"] == [4.0] * len(fix_t)
    assert np.array(gps["geometry"]["coordinates"]) == pytest.approx(
        np.column_stack([fix_lon, fix_lat]), abs=1e-7
    )
    # the first fix is where the prediction starts (both anchored there)
    assert coordinates[0] == pytest.approx([fix_lon[0], fix_lat[0]], abs=1e-7)


def test_a_walk_without_gps_cannot_go_on_a_map(client: TestClient, plain: dict) -> None:
    for name in ("trajectory.gpx", "trajectory.geojson"):
        response = client.get(f"/runs/{plain['run_id']}/{name}")
        assert response.status_code == 422
        assert "cannot be placed on a map" in detail(response) and "GPS" in detail(response)
    bad = client.get(f"/runs/{plain['run_id']}/trajectory.gpx", params={"fit": "best"})
    assert bad.status_code == 422 and "fit" in detail(bad)
    assert client.get("/runs/nosuchrun/trajectory.gpx").status_code == 404


def test_csv_and_tum_on_the_phones_clock(client: TestClient, plain: dict, start_epoch_s: float) -> None:
    run = f"/runs/{plain['run_id']}"
    relative = client.get(f"{run}/trajectory.csv").text.splitlines()
    epoch = client.get(f"{run}/trajectory.csv", params={"clock": "epoch"}).text.splitlines()
    columns = "x_m,y_m,z_m,sigma_x_m,sigma_y_m"
    first_rel = [float(v) for v in relative[relative.index(f"t_s,{columns}") + 1].split(",")]
    first_abs = [float(v) for v in epoch[epoch.index(f"t_unix_s,{columns}") + 1].split(",")]
    assert first_abs[0] == pytest.approx(start_epoch_s + first_rel[0], abs=2e-6)
    assert first_abs[1:] == first_rel[1:]
    tum = client.get(f"{run}/trajectory.tum", params={"clock": "epoch", "timestamps": "input"}).text
    rows = [line.split() for line in tum.splitlines() if not line.startswith("#")]
    assert float(rows[0][0]) == pytest.approx(start_epoch_s, abs=0.05) and "Unix time" in tum


def test_a_recording_without_a_start_time_says_so(client: TestClient, csv_without_gt: bytes) -> None:
    run_id = upload(client, csv_without_gt, "phone.csv").json()["run_id"]
    for name in ("trajectory.csv", "trajectory.tum"):
        response = client.get(f"/runs/{run_id}/{name}", params={"clock": "epoch"})
        assert response.status_code == 422
        assert "no start time on the phone's clock" in detail(response)
    assert client.get(f"/runs/{run_id}/metrics.json").json()["start_epoch_s"] is None
