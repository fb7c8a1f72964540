"""One phone's live recording: push messages in, a growing trajectory and its figures out.

``LiveSession.receive(message, now)`` takes one parsed message (in any order, duplicates included),
``tick(now)`` gives up on messages that stay missing, ``finish()`` uses what is left. After each,
``prediction()`` is the trajectory so far (views of the growing arrays, no copies) once the first
window has run.

Latency (``latencies_s``, per sample): from the arrival of the message that carried a sample to the
moment the trajectory covers it, i.e. a window (or, for streaming models, a frame) ending at or after
it was integrated and the result was handed on (``mark_effect``, called by whoever publishes it).
Samples are counted on the gyroscope's stream; each entry is ``(latency, samples)``.

``filter="ekf"``: the samples go through the EKF (``ftin.filter.session.FilterSession``) first, with
the causal orientation as its start and heading reference, and the incremental inference reads them
on the filter's orientation (an upload's levelled re-read, causal: the filter's estimate at a sample
is final once stepped; the causal orientation while the walk's mean NIS so far is over the uploads'
rule). The trajectory and its uncertainty are the model's, as without the filter; the filter's tilt
and biases are the scene's EKF plots (``docs/filter.md``, "Live sessions").
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data.types import ImuSequence, Trajectory
from ftin.filter import levelled
from ftin.filter.choice import EKF, NONE, ekf_series
from ftin.filter.run import NetworkVelocity
from ftin.filter.session import FilterSession
from ftin.filter.state import FilterConfig
from ftin.infer import FRAME_DEVICE_WORLD, Prediction
from ftin.live.formats.base import PushFormat
from ftin.live.grid import SensorStreams
from ftin.live.incremental import IncrementalPredictor
from ftin.live.messages import PushMessage
from ftin.live.ordering import MessageOrder
from ftin.live.orientation import CausalOrientation
from ftin.metrics.steps import StepDetector

LATENCIES_KEPT = 2048
# The sensors of each kind, in the order the clock prefers them (ftin.live.grid).
SENSOR_KINDS = {
    "gyro": ("Gyroscope", "GyroscopeUncalibrated"),
    "acc": ("TotalAcceleration", "Accelerometer", "AccelerometerUncalibrated"),
    "mag": ("Magnetometer", "MagnetometerUncalibrated"),
}


class LiveSession:
    def __init__(
        self,
        session_id: str,
        device_id: str,
        loaded: LoadedModel,
        push_format: PushFormat,
        *,
        platform: str | None = None,
        hold_s: float = 0.5,
        now_s: float | None = None,
        filter: str = NONE,
    ) -> None:
        now_s = time.monotonic() if now_s is None else now_s
        self.session_id, self.device_id = session_id, device_id
        self.model_name = loaded.name
        self.push_format = push_format
        self.source = f"live stream {device_id}/{session_id}"
        self.order = MessageOrder(hold_s)
        self.streams = SensorStreams(loaded.imu_rate_hz, push_format, platform, self.source)
        self.orientation = CausalOrientation(loaded.imu_rate_hz)
        self.model_rate_hz = float(loaded.imu_rate_hz)
        self.filter = filter
        # With the EKF the model reads the filter's orientation (``_levelled``); the offline heading
        # reference (auto's, forwards and backwards) does not exist live: the causal orientation's.
        self.levelling: FilterSession | None = None
        if filter == EKF:
            config = FilterConfig(heading_reference="causal")
            network = NetworkVelocity(loaded, config)  # ValueError for a streaming model
            self.levelling = FilterSession(network, loaded.window, config)
        self.predictor = IncrementalPredictor(loaded)
        self.step_detector = StepDetector(loaded.imu_rate_hz)  # the upload's detector, fed as samples come
        self.started_s = now_s
        self.last_message_s = now_s
        self.messages = 0
        self.test_pushes = 0
        self.skipped: dict[str, int] = {}
        self.error: str | None = None
        # Per message not yet covered: [first, last sample time, samples, arrival, samples settled].
        self._marks: deque[list[float]] = deque()
        self.latencies_s: deque[tuple[float, int]] = deque(maxlen=LATENCIES_KEPT)
        self.latest_latency_s: float | None = None

    # --- input -----------------------------------------------------------------------------------

    def receive(self, message: PushMessage, now_s: float) -> bool:
        """Take one message; True when the trajectory grew."""
        self.messages += 1
        self.last_message_s = now_s
        for name, count in message.skipped.items():
            if len(self.skipped) < 32 or name in self.skipped:
                self.skipped[name] = self.skipped.get(name, 0) + count
        return self._use(self.order.push(message, now_s), now_s)

    def tick(self, now_s: float) -> bool:
        """Give up on missing messages that waited long enough; True when the trajectory grew."""
        return self._use(self.order.due(now_s), now_s)

    def finish(self, now_s: float) -> bool:
        return self._use(self.order.due(now_s, flush=True), now_s)

    def _use(self, messages: list[PushMessage], now_s: float) -> bool:
        for message in messages:
            self.streams.add(message)
            gyro = message.sensors.get("Gyroscope", message.sensors.get("GyroscopeUncalibrated"))
            if gyro is not None and len(gyro.t_ns) and self.streams.origin_ns is not None:
                first, last = ((gyro.t_ns[[0, -1]] - self.streams.origin_ns) * 1e-9).tolist()
                self._marks.append([first, last, len(gyro.t_ns), now_s, 0])
            field = message.sensors.get("Magnetometer", message.sensors.get("MagnetometerUncalibrated"))
            if field is not None and len(field.t_ns) and self.streams.origin_ns is not None:
                t_s = (field.t_ns - self.streams.origin_ns).astype(np.float64) * 1e-9
                self.orientation.add_magnetometer(t_s, field.values)
        grew = False
        while (chunk := self.streams.take()) is not None:
            q = self.orientation.update(chunk)
            if self.levelling is not None:
                q = self._levelled(chunk.t_s, chunk.gyro_rad_s, chunk.acc_m_s2, q)
            grew |= self.predictor.extend(chunk.t_s, chunk.gyro_rad_s, chunk.acc_m_s2, q) > 0
            self.step_detector.update(chunk.t_s, chunk.acc_m_s2, chunk.gyro_rad_s)
        return grew

    def _levelled(self, t_s: np.ndarray, gyro: np.ndarray, acc: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The chunk through the EKF, and the orientation the model reads it with: the EKF's (causal: its
        estimate at a sample is final once stepped) while the network has agreed with the IMU so far
        (``ftin.filter.levelled.network_agreed``, the uploads' rule on the walk so far), else the causal
        orientation ``q``."""
        first = len(self.levelling)
        self.levelling.extend(t_s, gyro, acc, q)
        run = self.levelling.result()
        return run.q_world_device_wxyz[first:] if levelled.network_agreed(run.nis) else q

    def mark_effect(self, covered_s: float | None, now_s: float) -> None:
        """The trajectory up to ``covered_s`` is shown now: settle the latency of the messages in it."""
        if covered_s is None:
            return
        while self._marks and self._marks[0][0] <= covered_s + 1e-9:
            first, last, n, arrival, settled = self._marks[0]
            if covered_s + 1e-9 >= last:
                now_covered = n
                self._marks.popleft()
            else:  # part of the message: its samples are evenly spread over [first, last]
                now_covered = min(n, int((covered_s - first) / (last - first) * (n - 1)) + 1)
                self._marks[0][4] = now_covered
            if now_covered > settled:
                self.latest_latency_s = now_s - arrival
                self.latencies_s.append((self.latest_latency_s, int(now_covered - settled)))
            if now_covered < n:
                break
        while len(self._marks) > LATENCIES_KEPT:  # messages the model never covers (a stalled sensor)
            self._marks.popleft()

    # --- output ----------------------------------------------------------------------------------

    @property
    def has_trajectory(self) -> bool:
        return self.predictor.n_spans > 0

    @property
    def n_samples(self) -> int:
        return len(self.predictor)

    @property
    def duration_s(self) -> float:
        t = self.predictor.t_s()
        return float(t[-1] - t[0]) if len(t) > 1 else 0.0

    @property
    def dropped_messages(self) -> int:
        return self.order.lost + self.order.late

    @property
    def steps(self) -> int:
        return self.step_detector.count  # exactly the upload's count of the samples so far

    def distance_m(self) -> float:
        """Horizontal path length so far."""
        return self.predictor.path_length_m()

    def rate_hz(self) -> float:
        """The phone's gyroscope rate as it arrives."""
        rates = self.streams.sensor_rates_hz()
        return float(rates.get("Gyroscope", rates.get("GyroscopeUncalibrated", 0.0)))

    def rates_by_kind(self) -> dict[str, float | None]:
        """The rate of each kind of sensor as it arrives (Hz; None: not streamed): a phone may log its
        gyroscope at 500 Hz and its accelerometer at 100 Hz."""
        rates = self.streams.sensor_rates_hz()
        return {
            kind: next((rates[name] for name in names if name in rates), None)
            for kind, names in SENSOR_KINDS.items()
        }

    def latency_summary(self) -> dict[str, float | None]:
        if not self.latencies_s:
            return {"median_s": None, "p95_s": None}
        values, weights = np.asarray(self.latencies_s).T
        return {
            "median_s": weighted_quantile(values, weights, 0.5),
            "p95_s": weighted_quantile(values, weights, 0.95),
        }

    def warnings(self) -> list[str]:
        notes = list(self.streams.warnings)
        if self.orientation.source == "estimated":
            estimate = self.orientation.describe()
            notes.append(
                f"{self.source}: no orientation streamed; estimated causally with {estimate}: "
                f"tick Orientation in {self.push_format.app} for the phone's own"
            )
        if self.dropped_messages:
            notes.append(
                f"{self.dropped_messages} push message(s) lost or too late; "
                f"{self.streams.gaps_filled} gap(s) filled with the earlier stretch that fits them best"
            )
        return notes

    def sequence(self, name: str) -> ImuSequence:
        """What was received, on the model's clock (views; the run's sequence)."""
        received = self.levelling or self.predictor  # the causal orientation, not the one the model read
        t = received.t_s()
        gyro, acc, q = received.imu()
        rate = self.model_rate_hz
        meta: dict[str, Any] = {
            "dataset": f"{self.push_format.name}-live",
            "source": self.source,
            "rate_hz": rate,
            "carry": "unknown",
            "frame": "device_world",
            "orientation_source": self.orientation.source or "device",
            "sensor_rates_hz": self.streams.sensor_rates_hz(),
            "warnings": self.warnings(),
        }
        if self.orientation.source == "estimated":
            meta["orientation_filter"] = self.orientation.filter_name
        return ImuSequence(name, t, gyro, acc, q, None, meta)

    def prediction(self) -> Prediction:
        p = self.predictor
        t = p.t_s()
        mid, span_t = p.span_times()
        _, _, velocity = p.spans()
        # a variance head's per-window sigma, so a live walk's uncertainty is an upload's
        features = None if (log_std := p.log_std()) is None else {"log_std": log_std}
        prediction = Prediction(
            trajectory=Trajectory(t, p.positions(), p.imu()[2]),
            window_t_s=mid,
            velocity_m_s=velocity,
            orientation_source=self.orientation.source or "device",
            frame=FRAME_DEVICE_WORLD,
            warnings=self.warnings(),
            features=features,
            span_t_s=span_t,
        )
        if self.levelling is not None:
            self._name_the_filter(prediction, self.levelling)
        return prediction

    def _name_the_filter(self, prediction: Prediction, session: FilterSession) -> None:
        """A levelled live run (``_levelled``): named ``ekf`` as an upload's, the filter's tilt and bias
        series for the scene's plots, and a note on whose orientation the model read."""
        run = session.result()
        prediction.orientation_filter = EKF
        series = ekf_series(run, session.imu()[2])
        prediction.features = {**(prediction.features or {}), "filter_series": series}
        if not len(run.nis):
            return
        mean_nis = float(np.mean(run.nis))
        if levelled.network_agreed(run.nis):
            prediction.notes.append(f"read on the EKF's causal orientation (mean NIS so far {mean_nis:.1f})")
        else:
            prediction.notes.append(
                f"read on the causal orientation while the network disagrees with the IMU (mean NIS so far"
                f" {mean_nis:.1f} > {levelled.MAX_MEAN_NIS:g}), on the EKF's while it agreed"
            )


def weighted_quantile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """The ``q`` quantile of ``values`` each repeated ``weights`` times (the lower one at a tie)."""
    order = np.argsort(values)
    cumulative = np.cumsum(np.asarray(weights, dtype=np.float64)[order])
    index = int(np.searchsorted(cumulative, q * cumulative[-1]))
    return float(np.asarray(values)[order][min(index, len(order) - 1)])
