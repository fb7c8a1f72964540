"""A run's predicted walk in latitude / longitude, for maps: GPX 1.1 and GeoJSON
(``GET /runs/{run_id}/trajectory.gpx`` and ``.../trajectory.geojson``).

Decisions:
- Only a walk with GPS can be placed on the Earth: the prediction is anchored to the export's GPS
  track by ``ftin.metrics.gps_anchor`` (``fit=start``: the start alignment the page and the scene
  draw, the default; ``fit=walk``: a rigid fit onto every fix). Without GPS, or with fewer than two
  fixes inside the recording, ``InvalidInputError`` (HTTP 422) says so.
- Points every ``TRACK_STEP_S`` seconds (and the last one): about 0.7 m apart at a walking pace,
  finer than the model resolves (its window is a second), and a 30-minute walk stays a few MB.
- Times: GPX and GeoJSON carry UTC times when the recording knows its start on the phone's clock
  (``ftin.data.epoch``); without one the GPX points carry no ``<time>`` (optional in GPX 1.1) and
  both files say why. GeoJSON has no standard for times: ``properties.times`` (ISO 8601, one per
  coordinate) beside ``properties.t_s`` (seconds from the start), as map tools' converters write.
- Both files also hold the GPS fixes inside the recording (a second track / feature), so that a map
  shows the prediction beside what the phone measured; fixes from before or after it are left out.
- Coordinates with 7 decimals (about 1 cm); GeoJSON in RFC 7946's order, longitude first.
"""

from __future__ import annotations

import datetime as dt
from typing import Any
from xml.sax.saxutils import escape

import numpy as np

from app.services.errors import InvalidInputError
from app.services.runs import Run
from ftin.data.epoch import start_epoch_s
from ftin.data.location import GpsTrack
from ftin.data.trajectory_io import at_times
from ftin.metrics.gps_anchor import AnchorFit, GeoPath, NoAnchorError, anchor_on_gps

TRACK_STEP_S = 0.5
GPX_NS = "http://www.topografix.com/GPX/1/1"
NO_TIME = "the recording has no start time on the phone's clock, so the points carry no time"


def _track(run: Run) -> GpsTrack | None:
    track = run.sequence.meta.get("gps")
    return track if isinstance(track, GpsTrack) else None


def geo_path(run: Run, fit: AnchorFit | str = AnchorFit.START) -> GeoPath:
    """The run's prediction every ``TRACK_STEP_S`` in latitude / longitude, or 422 without GPS."""
    traj = run.prediction.trajectory
    t0, t1 = float(traj.t_s[0]), float(traj.t_s[-1])
    grid = np.unique(np.append(np.arange(t0, t1, TRACK_STEP_S), t1))
    comparison = run.plausibility.gps  # the start alignment the page shows, computed once per run
    try:
        return anchor_on_gps(at_times(traj, grid), _track(run), fit, comparison=comparison)
    except NoAnchorError as exc:
        raise InvalidInputError(
            f"{run.sequence.name} cannot be placed on a map: {exc}. GPX and GeoJSON need a phone export "
            "with GPS (Location.csv) recorded during the walk; the CSV and TUM downloads work without."
        ) from None


def _fixes(run: Run) -> GpsTrack | None:
    """The GPS fixes inside the prediction's time span."""
    track, traj = _track(run), run.prediction.trajectory
    if track is None:
        return None
    inside = (track.t_s >= traj.t_s[0]) & (track.t_s <= traj.t_s[-1])
    return GpsTrack(
        *(a[inside] for a in (track.t_s, track.lat_deg, track.lon_deg, track.altitude_m, track.accuracy_m)),
        source=track.source,
    )


def iso_utc(epoch_s: float) -> str:
    stamp = dt.datetime.fromtimestamp(epoch_s, tz=dt.timezone.utc)
    return stamp.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _name(run: Run) -> str:
    return f"{run.model_name} on {run.sequence.name}"


def gpx_text(run: Run, fit: AnchorFit | str = AnchorFit.START) -> str:
    """GPX 1.1: the prediction as one track, the GPS fixes as another (module docstring)."""
    path, fixes = geo_path(run, fit), _fixes(run)
    start = start_epoch_s(run.sequence.meta)
    desc = path.text + ("" if start is not None else f" No times: {NO_TIME}.")
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<gpx version="1.1" creator="FTIN Studio" xmlns="{GPX_NS}" '
        'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
        f'xsi:schemaLocation="{GPX_NS} {GPX_NS}/gpx.xsd">',
        "  <metadata>",
        f"    <name>{escape(_name(run))}</name>",
        f"    <desc>{escape(desc)}</desc>",
        *([] if start is None else [f"    <time>{iso_utc(start)}</time>"]),
        "  </metadata>",
    ]

    def track(name: str, desc: str, t_s: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> None:
        lines.extend(["  <trk>", f"    <name>{escape(name)}</name>", f"    <desc>{escape(desc)}</desc>"])
        lines.append("    <trkseg>")
        for t, la, lo in zip(t_s, lat, lon, strict=True):
            time = "" if start is None else f"<time>{iso_utc(start + float(t))}</time>"
            lines.append(f'      <trkpt lat="{la:.7f}" lon="{lo:.7f}">{time}</trkpt>')
        lines.extend(["    </trkseg>", "  </trk>"])

    track(f"{_name(run)} (predicted)", path.text, path.t_s, path.lat_deg, path.lon_deg)
    if fixes is not None and len(fixes):
        track(
            "GPS fixes",
            f"The phone's GPS fixes during the walk ({fixes.source}).",
            fixes.t_s,
            fixes.lat_deg,
            fixes.lon_deg,
        )
    lines.append("</gpx>")
    return "\n".join(lines) + "\n"


def _feature(
    name: str, kind: str, t_s: np.ndarray, lat: np.ndarray, lon: np.ndarray, start: float | None, **more: Any
) -> dict[str, Any]:
    coordinates = [[round(float(lo), 7), round(float(la), 7)] for la, lo in zip(lat, lon, strict=True)]
    properties: dict[str, Any] = {"name": name, "kind": kind, **more}
    properties["t_s"] = [round(float(t), 3) for t in t_s]
    if start is not None:
        properties["times"] = [iso_utc(start + float(t)) for t in t_s]
    return {
        "type": "Feature",
        "geometry": {"type": "LineString", "coordinates": coordinates},
        "properties": properties,
    }


def geojson(run: Run, fit: AnchorFit | str = AnchorFit.START) -> dict[str, Any]:
    """A GeoJSON FeatureCollection: the prediction's LineString, then the GPS fixes' (module docstring)."""
    path, fixes = geo_path(run, fit), _fixes(run)
    start = start_epoch_s(run.sequence.meta)
    features = [
        _feature(
            f"{_name(run)} (predicted)",
            "prediction",
            path.t_s,
            path.lat_deg,
            path.lon_deg,
            start,
            model=run.model_name,
            sequence=run.sequence.name,
            run_id=run.run_id,
            anchor=path.fit.value,
            anchor_text=path.text,
            start_time=None if start is None else iso_utc(start),
            time_note=None if start is not None else NO_TIME,
        )
    ]
    if fixes is not None and len(fixes) >= 2:  # a LineString needs two positions
        accuracy = [None if not np.isfinite(a) else float(a) for a in fixes.accuracy_m]
        features.append(
            _feature("GPS fixes", "gps", fixes.t_s, fixes.lat_deg, fixes.lon_deg, start, accuracy_m=accuracy)
        )
    return {"type": "FeatureCollection", "features": features}
