"""A live phone's sensors, each on its own clock and rate, merged onto the model's uniform clock as
they arrive, in the units and signs of the Sensor Logger reader (whose sensor names every push format
uses, ``ftin.live.messages``).

``SensorStreams.add(message)`` keeps a short history per sensor; ``take()`` returns the clock
samples that every required sensor now covers (a ``GridChunk``), each exactly once.

Decisions:
- The clock is uniform at the model's rate (no second resampling, as ``ftin.data.prepare`` would do
  offline), from the instant every required sensor has started; time 0 is the session's first
  sample. A sample reaches the clock once every required sensor has data one clock step past it.
- Merging, units and signs are the export reader's own (``sensor_clock.on_clock``, the
  ``sensorlogger.acceleration_keys`` choice, ``acceleration_scale``, ``gravity_sign``,
  ``gyro_scale_from_gravity``), decided once on the first ``CALIBRATION_S`` seconds and kept: a
  causal stream cannot look at the whole recording as the reader does.
- The push format (``ftin.live.formats``) names the app in the advice of errors and states the
  gyroscope's unit, which the gravity-turn fit checks.
- Push messages carry no platform: the phone's orientation decides the acceleration sign (as in the
  reader); without orientation a ``platform`` given with the push URL does, else Android's
  convention is assumed with a warning.
- Samples at or before a sensor's latest time are dropped (a duplicate or late message); the
  history kept per sensor is ``HISTORY_S``, so memory does not grow with the session.
- A gap (a lost message) is filled when the message after it arrives, with the earlier stretch of the
  recording that fits it best (``ftin.live.gapfill``: the lag whose surroundings match the samples on
  both sides of the gap, one lag for every sensor), and the attitude that went with that stretch,
  turned to meet both sides; not bridged by a straight line: a model reads a straight line as
  standing still (up to ``STALL_MAX_S``). The filled samples are handed out only once the message
  after the gap is in, so a message that arrives later still is counted late and dropped
  (``ftin.live.ordering``), never added twice. The warnings count the filled gaps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import ftin.data.io.sensor_clock as sensor_clock
from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io.sensor_clock import SensorSeries
from ftin.data.readers.sensorlogger import acceleration_keys
from ftin.live import gapfill
from ftin.live.formats.base import PushFormat
from ftin.live.messages import PushMessage

CALIBRATION_S = 2.0  # data seen before units and signs are settled (and the first window can run)
HISTORY_S = 2.5  # raw samples kept behind the clock (interpolation, gap checks)
# A sensor silent this long while the others go on has stopped: a live session cannot hold a hole
# open and predict around it later as an upload does (ftin.data.gaps), so it ends with the reason.
STALL_MAX_S = 5.0
MAX_WARNINGS = 20
GIVE_UP_S = 10.0  # data without the sensors odometry needs: an error, not an ever-growing buffer
FILL_GAP_FACTOR, MIN_FILLED_GAP_S = 3.0, 0.05  # a gap: several sample intervals and 50 ms at least
FILL_PERIOD_S = 1.0  # without history enough to search: the stretch this far back (about two steps)
GYRO_KEYS = ("Gyroscope", "GyroscopeUncalibrated")
ACC_KEYS = ("TotalAcceleration", "Accelerometer", "AccelerometerUncalibrated")
MATCHED_SENSORS = (*GYRO_KEYS, *ACC_KEYS)


@dataclass(frozen=True)
class GridChunk:
    t_s: np.ndarray  # (n,) seconds since the session's first sample, uniform
    gyro_rad_s: np.ndarray  # (n, 3) device frame
    acc_m_s2: np.ndarray  # (n, 3) specific force, device frame
    q_device_wxyz: np.ndarray | None  # (n, 4) the phone's world-from-device orientation, if streamed

    def __len__(self) -> int:
        return len(self.t_s)


@dataclass
class _Calibration:
    gyro_key: str
    acc_keys: list[str]
    use_orientation: bool
    invert_orientation: bool
    acc_factor: float  # unit scale times sign
    gyro_factor: float
    grid_start_s: float

    @property
    def required(self) -> list[str]:
        return [self.gyro_key, *self.acc_keys, *(["Orientation"] if self.use_orientation else [])]


class SensorStreams:
    def __init__(
        self,
        rate_hz: float,
        push_format: PushFormat,
        platform: str | None = None,
        source: str = "live stream",
    ) -> None:
        self.rate_hz = float(rate_hz)
        self.push_format = push_format
        self.platform = platform
        self.source = source
        self.origin_ns: int | None = None
        self._t: dict[str, np.ndarray] = {}
        self._v: dict[str, np.ndarray] = {}
        self._first_t: dict[str, float] = {}
        self.calibration: _Calibration | None = None
        self.next_index = 0  # next clock sample to hand out
        self.samples_in = 0
        self.samples_dropped = 0  # at or before their sensor's latest time
        self.gaps_filled = 0
        self.warnings: list[str] = []

    # --- input -----------------------------------------------------------------------------------

    def add(self, message: PushMessage) -> None:
        kept: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for sensor, batch in message.sensors.items():
            if not len(batch.t_ns):
                continue
            if self.origin_ns is None:
                self.origin_ns = min(int(b.t_ns[0]) for b in message.sensors.values() if len(b.t_ns))
            t = (batch.t_ns - self.origin_ns).astype(np.float64) * 1e-9
            last = self._t[sensor][-1] if sensor in self._t and len(self._t[sensor]) else -np.inf
            keep = t > last
            keep[1:] &= np.diff(t) > 0  # repeated stamps inside one message
            self.samples_in += len(t)
            self.samples_dropped += int((~keep).sum())
            if keep.any():
                kept[sensor] = (t[keep], batch.values[keep])
        holes = [
            sensor
            for sensor, (t, _) in kept.items()
            if sensor != "Orientation" and self._has_hole(sensor, float(t[0]))
        ]
        if holes:
            self._fill_holes(holes, kept)
        for sensor, (t, v) in kept.items():
            if sensor in self._t:
                self._t[sensor] = np.concatenate([self._t[sensor], t])
                self._v[sensor] = np.concatenate([self._v[sensor], v])
            else:
                self._t[sensor], self._v[sensor] = t, v
                self._first_t[sensor] = float(t[0])

    def _has_hole(self, sensor: str, next_t: float) -> bool:
        """Whether ``sensor``'s samples resume at ``next_t`` after a gap that is filled."""
        history_t = self._t.get(sensor)
        if history_t is None or len(history_t) < 8:
            return False
        dt = float(np.median(np.diff(history_t[-64:])))
        return max(FILL_GAP_FACTOR * dt, MIN_FILLED_GAP_S) < next_t - float(history_t[-1]) <= STALL_MAX_S

    def _fill_holes(self, holes: list[str], kept: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """Put a filled stretch before the new samples of every sensor in ``holes``
        (``ftin.live.gapfill``: one source lag for all, the earlier stretch that fits both sides best)."""
        hole = (min(float(self._t[k][-1]) for k in holes), max(float(kept[k][0][0]) for k in holes))
        # The lag is matched on what moves with the gait (rates and accelerations), not on the slow
        # gravity and magnetic field, which would pick a stretch of the same heading instead.
        matched = [k for k in holes if k in MATCHED_SENSORS] or holes
        lag = gapfill.choose_lag(
            [(self._t[k], self._v[k]) for k in matched], [kept[k] for k in matched], *hole
        )
        q_next = kept.get("Orientation")
        if lag is not None and self.calibration is not None and q_next is not None:
            if self._has_hole("Orientation", float(q_next[0][0])):
                # Else the attitude is interpolated across the hole (before the calibration has said
                # which way the phone's quaternions turn).
                fill_t = self._fill_times("Orientation", float(q_next[0][0]))
                fill_q = gapfill.filled_attitude(
                    self._t["Orientation"],
                    self._v["Orientation"],
                    fill_t,
                    lag,
                    float(q_next[0][0]),
                    q_next[1][0],
                    self.calibration.invert_orientation,
                )
                if fill_q is not None:
                    kept["Orientation"] = (
                        np.concatenate([fill_t, q_next[0]]),
                        np.concatenate([fill_q, q_next[1]]),
                    )
        for sensor in holes:
            history_t, history_v = self._t[sensor], self._v[sensor]
            t, v = kept[sensor]
            fill_t = self._fill_times(sensor, float(t[0]))
            if lag is None:  # too little history to search: repeat the stretch before the gap
                last = float(history_t[-1])
                period = min(max(float(t[0]) - last, FILL_PERIOD_S), last - float(history_t[0]))
                fill_v = gapfill.copied(
                    history_t, history_v, last - period + np.mod(fill_t - last, period), 0.0
                )
            else:
                fill_v = gapfill.copied(history_t, history_v, fill_t, lag)
            kept[sensor] = (np.concatenate([fill_t, t]), np.concatenate([fill_v, v]))
        self.gaps_filled += 1

    def _fill_times(self, sensor: str, next_t: float) -> np.ndarray:
        """The sample times of the filled stretch, at ``sensor``'s own rate, up to ``next_t``."""
        history_t = self._t[sensor]
        dt = float(np.median(np.diff(history_t[-64:])))
        last = float(history_t[-1])
        return last + dt * np.arange(1, int(np.floor((next_t - last - 0.5 * dt) / dt)) + 1)

    def sensor_rates_hz(self) -> dict[str, float]:
        return {
            name: round(float(1.0 / np.median(np.diff(t))), 1) for name, t in self._t.items() if len(t) > 2
        }

    # --- output ----------------------------------------------------------------------------------

    def take(self) -> GridChunk | None:
        """The clock samples that are complete now and were not handed out yet (None: none)."""
        if self.calibration is None:
            self.calibration = self._calibrate()
            if self.calibration is None:
                return None
        cal = self.calibration
        step = 1.0 / self.rate_hz
        ends = {k: float(self._t[k][-1]) for k in cal.required}
        newest = max(float(t[-1]) for t in self._t.values())
        stalled = min(ends, key=ends.__getitem__)
        if newest - ends[stalled] > STALL_MAX_S:
            raise DataFormatError(
                f"{self.source}: {stalled} stopped arriving {newest - ends[stalled]:.1f} s ago while other "
                "sensors go on; the trajectory cannot continue without it "
                f"(tick it in {self.push_format.app} again)"
            )
        covered = min(ends.values()) - step
        end = int(np.floor((covered - cal.grid_start_s) * self.rate_hz + 1e-9)) + 1
        if end - self.next_index < 2:
            return None
        grid = cal.grid_start_s + np.arange(self.next_index, end) / self.rate_hz
        self.next_index = end
        chunk = self._convert(cal, grid)
        self._trim(grid[-1] - HISTORY_S)
        return chunk

    def _series(self, key: str) -> SensorSeries:
        return SensorSeries(f"{key} stream", self._t[key], self._v[key])

    def _on_clock(self, key: str, grid: np.ndarray) -> np.ndarray:
        return sensor_clock.on_clock(self._series(key), grid, self.source, self._warn_list())

    def _warn_list(self) -> list[str]:
        return _UniqueWarnings(self.warnings)

    def _calibrate(self) -> _Calibration | None:
        gyro_key = next((k for k in GYRO_KEYS if k in self._t), None)
        acc_present = [
            k for k in ("TotalAcceleration", "Accelerometer", "AccelerometerUncalibrated") if k in self._t
        ]
        if gyro_key is None or not acc_present:
            longest = max((float(t[-1] - t[0]) for t in self._t.values() if len(t)), default=0.0)
            if longest > GIVE_UP_S:
                missing = "a gyroscope" if gyro_key is None else "an accelerometer"
                raise DataFormatError(
                    f"{self.source}: {longest:.0f} s of data ({', '.join(sorted(self._t))}) and no "
                    f"{missing.split()[-1]}: tick {missing} (and gravity or total acceleration) in "
                    f"{self.push_format.app}'s sensor list"
                )
            return None
        spans = [self._t[k][-1] - self._t[k][0] for k in (gyro_key, *acc_present)]
        if min(spans) < CALIBRATION_S:
            return None
        if "Accelerometer" in self._t and "Gravity" not in self._t and "TotalAcceleration" not in self._t:
            if self._t["Accelerometer"][-1] - self._first_t["Accelerometer"] < 2 * CALIBRATION_S:
                return None  # give Gravity a little longer to show up
        series = {k: self._series(k) for k in self._t if k not in ("Orientation",)}
        warnings = self._warn_list()
        acc_keys = acceleration_keys(series, self.source, ", ".join(sorted(self._t)) or "no sensors")
        use_q = "Orientation" in self._t and len(self._t["Orientation"]) > 2
        required = [gyro_key, *acc_keys, *(["Orientation"] if use_q else [])]
        start = max(float(self._t[k][0]) for k in required)
        covered = min(float(self._t[k][-1]) for k in required) - 1.0 / self.rate_hz
        if covered - start < 0.5 * CALIBRATION_S:
            return None
        grid = start + np.arange(int(np.floor((covered - start) * self.rate_hz)) + 1) / self.rate_hz
        on = {k: self._on_clock(k, grid) for k in (gyro_key, *acc_keys)}
        if len(acc_keys) == 2:
            scale = sensor_clock.acceleration_scale(on["Gravity"], "Gravity stream", self.source, warnings)
            total, gravity = (on["Accelerometer"] + on["Gravity"]) * scale, on["Gravity"] * scale
        else:
            scale = sensor_clock.acceleration_scale(
                on[acc_keys[0]], f"{acc_keys[0]} stream", self.source, warnings
            )
            total, gravity = on[acc_keys[0]] * scale, None
        q_raw = self._orientation(grid) if use_q else None
        sign, q = sensor_clock.gravity_sign(q_raw, total, self.platform, self.source, warnings)
        invert = q is not None and q_raw is not None and not np.allclose(q, q_raw)
        acc = sign * total
        up = sign * gravity if gravity is not None else sensor_clock.low_pass(acc, grid)
        # The export's rule: the app states its unit, the gravity-turn fit only checks it (and the sign).
        gyro_factor = sensor_clock.gyro_scale_from_gravity(
            grid, on[gyro_key], up, self.source, warnings, stated_unit=self.push_format.gyro_unit
        )
        return _Calibration(gyro_key, acc_keys, q is not None, invert, scale * sign, gyro_factor, start)

    def _orientation(self, grid: np.ndarray) -> np.ndarray:
        t, q = self._t["Orientation"], self._v["Orientation"]
        norms = np.linalg.norm(q, axis=1)
        valid = np.abs(norms - 1.0) < 0.1
        if valid.sum() < 2:
            raise DataFormatError(f"{self.source}: the orientation stream holds no unit quaternions")
        q = frames.make_continuous(q[valid] / norms[valid, None])
        out = np.column_stack([np.interp(grid, t[valid], q[:, c]) for c in range(4)])
        return out / np.linalg.norm(out, axis=1, keepdims=True)

    def _convert(self, cal: _Calibration, grid: np.ndarray) -> GridChunk:
        gyro = self._on_clock(cal.gyro_key, grid) * cal.gyro_factor
        on = [self._on_clock(k, grid) for k in cal.acc_keys]
        acc = (on[0] + on[1] if len(on) == 2 else on[0]) * cal.acc_factor
        sensor_clock.check_imu(gyro, acc, self.source)
        q = None
        if cal.use_orientation:
            q = self._orientation(grid)
            if cal.invert_orientation:
                q = q * np.array([1.0, -1.0, -1.0, -1.0])
        return GridChunk(grid, gyro, acc, q)

    def _trim(self, before_s: float) -> None:
        for key, t in self._t.items():
            cut = int(np.searchsorted(t, before_s))
            if cut > 0 and len(t) - cut >= 2:
                self._t[key], self._v[key] = t[cut:], self._v[key][cut:]


class _UniqueWarnings(list):
    """A list view that appends to ``target`` only new messages, and at most ``MAX_WARNINGS``."""

    def __init__(self, target: list[str]) -> None:
        super().__init__()
        self._target = target

    def append(self, message: str) -> None:
        if message not in self._target and len(self._target) < MAX_WARNINGS:
            self._target.append(message)
