"""Steps and cadence from the accelerometer alone, whatever way the phone is carried.

``detect_steps(t_s, acc_m_s2)`` returns the step times of a recording (``Steps``).

Decisions:
- The signal is the norm of the specific force: it needs no orientation, so a phone in a hand, a
  pocket, a swinging arm or a bag gives the same kind of signal (one bump per heel strike). It is
  band-passed (``BAND_HZ``: walking's step rate is 1-2.5 Hz, running's up to 3.5 Hz) with a
  zero-phase Butterworth filter.
- The step period is read from the autocorrelation of the filtered signal over sliding windows of
  ``WINDOW_S``: the first strong peak between ``MIN_PERIOD_S`` and ``MAX_PERIOD_S``. A pocket or a
  swinging arm moves once per stride (two steps), so a peak at half a stronger lag that is nearly as
  strong (``HALF_LAG_SHARE``) is taken as the step: the step rate is the rate of heel strikes.
- A phone on a limb (a pocket on the thigh, a swinging hand) turns fast (band-passed rotation rate
  above ``LIMB_GYRO_RAD_S``, when the gyroscope is given) and its specific force can repeat once per
  stride with no peak at the step at all; there a period of ``STRIDE_MIN_S`` or more is a stride
  and is halved. (Hand-held, texting and bag walks turn at 0.25-0.7 rad/s, pockets and swinging
  arms at 0.8-2.2, runs at 2-3.4, measured on RIDI and the Inria walks.)
- A window is walking when its autocorrelation peak reaches ``MIN_PERIODICITY`` (a rhythm, not a
  jolt) and its filtered signal moves more than ``MIN_STD_M_S2`` (a phone lying still has a rhythm
  of noise only). Windows overlap by ``HOP_S``; a sample is walking when a window around it is.
- Steps are the peaks of the filtered signal inside walking spans, no closer than
  ``REFRACTORY_SHARE`` of the local step period (the refractory period), with a prominence of at
  least ``PROMINENCE_SHARE`` of the local signal's standard deviation: harmonics of a heel strike
  (the signal has several bumps per step) fall inside the refractory period.
- Cadence is steps per minute of walking (not of the whole recording): walking time is the time
  between the steps of each bout (steps no further apart than ``BOUT_GAP_SHARE`` local periods) plus
  one period a bout, so standing at the start and end of a recording does not lower it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, find_peaks, sosfiltfilt

BAND_HZ = (0.6, 3.5)
MIN_PERIOD_S = 0.28  # 214 steps/min: running
MAX_PERIOD_S = 1.2  # 50 steps/min: a very slow walk
WINDOW_S = 4.0
HOP_S = 0.5
MIN_PERIODICITY = 0.3
MIN_STD_M_S2 = 0.15
HALF_LAG_SHARE = 0.4
REFRACTORY_SHARE = 0.6
PROMINENCE_SHARE = 0.3
MIN_SAMPLES = 32
LIMB_GYRO_RAD_S = 0.8
STRIDE_MIN_S = 0.9
EDGE_SHARE = 0.5
BOUT_GAP_SHARE = 2.0


@dataclass(frozen=True)
class Steps:
    """The steps of one recording: when they fell and the walking time they span."""

    t_s: np.ndarray  # (S,) time of each step (a peak of the filtered specific-force norm)
    walking_s: float  # seconds spent walking (the spans in which steps are counted)
    period_s: float | None  # median step period while walking (None: no walking found)

    @property
    def count(self) -> int:
        return len(self.t_s)

    @property
    def cadence_per_min(self) -> float | None:
        """Steps per minute of walking (None: too few steps to say)."""
        if self.count < 2 or self.walking_s <= 0:
            return None
        return 60.0 * self.count / self.walking_s


def _band(values: np.ndarray, rate_hz: float) -> np.ndarray:
    high = min(BAND_HZ[1], 0.45 * rate_hz)
    sos = butter(2, [BAND_HZ[0], high], btype="band", fs=rate_hz, output="sos")
    return sosfiltfilt(sos, values - values.mean(axis=0), axis=0)


def step_signal(t_s: np.ndarray, acc_m_s2: np.ndarray) -> tuple[np.ndarray, float]:
    """The band-passed specific-force norm and the sample rate it was filtered at."""
    t = np.asarray(t_s, dtype=np.float64)
    norm = np.linalg.norm(np.asarray(acc_m_s2, dtype=np.float64), axis=1)
    rate_hz = 1.0 / float(np.median(np.diff(t)))
    return _band(norm, rate_hz), rate_hz


def _period(segment: np.ndarray, rate_hz: float) -> tuple[float, float]:
    """``(step period s, autocorrelation at it)`` of one window of the filtered signal."""
    x = segment - segment.mean()
    energy = float(np.dot(x, x))
    if energy <= 0.0:
        return 0.0, 0.0
    n = len(x)
    spectrum = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(spectrum * np.conj(spectrum))[:n]
    ac = ac / energy * n / np.maximum(n - np.arange(n), 1)  # unbiased: long lags are not shrunk
    lo, hi = int(MIN_PERIOD_S * rate_hz), min(int(MAX_PERIOD_S * rate_hz) + 1, n - 1)
    if hi <= lo + 2:
        return 0.0, 0.0
    peaks, _ = find_peaks(ac[lo:hi])
    if len(peaks) == 0:
        return 0.0, 0.0
    lags = peaks + lo
    best = lags[np.argmax(ac[lags])]
    # A stride (two steps) may correlate more than a step: prefer half of it when it is nearly as strong.
    half = [lag for lag in lags if abs(lag - best / 2) <= 0.15 * best]
    if half:
        candidate = max(half, key=lambda lag: ac[lag])
        if ac[candidate] >= max(HALF_LAG_SHARE * ac[best], MIN_PERIODICITY):
            best = candidate
    return best / rate_hz, float(ac[best])


def detect_steps(t_s: np.ndarray, acc_m_s2: np.ndarray, gyro_rad_s: np.ndarray | None = None) -> Steps:
    """The steps in a recording's specific force (``(N, 3)`` m/s², any device frame); the gyroscope
    (``(N, 3)`` rad/s), when given, tells a phone on a limb (module docstring)."""
    t = np.asarray(t_s, dtype=np.float64)
    if len(t) < MIN_SAMPLES or not np.all(np.diff(t) > 0) or 0.45 / np.median(np.diff(t)) <= 2 * BAND_HZ[0]:
        return Steps(np.empty(0), 0.0, None)  # too short, unordered, or sampled too slowly for steps
    signal, rate_hz = step_signal(t, acc_m_s2)
    n, width = len(signal), max(int(round(WINDOW_S * rate_hz)), MIN_SAMPLES)
    hop = max(int(round(HOP_S * rate_hz)), 1)
    turning = None
    if gyro_rad_s is not None:
        turning = np.sum(_band(np.asarray(gyro_rad_s, dtype=np.float64), rate_hz) ** 2, axis=1)
    period = np.zeros(n)  # local step period, 0 where not walking
    weight = np.zeros(n)
    for start in range(0, max(n - width, 0) + 1, hop):
        segment = signal[start : start + width]
        if segment.std() < MIN_STD_M_S2:
            continue
        p, strength = _period(segment, rate_hz)
        on_limb = turning is not None and np.sqrt(turning[start : start + width].mean()) >= LIMB_GYRO_RAD_S
        if on_limb and p >= STRIDE_MIN_S:
            p /= 2.0
        if p > 0 and strength >= MIN_PERIODICITY:
            # the window's middle half gets its period (edges belong more to the neighbours)
            a, b = start + width // 4, start + 3 * width // 4
            if start == 0:
                a = 0
            if start + width >= n - hop:
                b = n
            period[a:b] += p * strength
            weight[a:b] += strength
    walking = weight > 0
    if not walking.any():
        return Steps(np.empty(0), 0.0, None)
    period[walking] /= weight[walking]
    median_period = float(np.median(period[walking]))
    distance = max(int(REFRACTORY_SHARE * median_period * rate_hz), 1)
    scale = float(signal[walking].std())
    peaks, _ = find_peaks(signal, distance=distance, prominence=PROMINENCE_SHARE * scale)
    # the refractory period follows the local period: drop a peak closer than that to the last kept
    kept: list[int] = []
    for peak in peaks:
        if not walking[peak] or min(t[peak] - t[0], t[-1] - t[peak]) < EDGE_SHARE * period[peak]:
            continue
        if kept and t[peak] - t[kept[-1]] < REFRACTORY_SHARE * period[peak]:
            if signal[peak] > signal[kept[-1]]:
                kept[-1] = peak
            continue
        kept.append(int(peak))
    times = t[kept]
    return Steps(times, _walking_s(times, period[kept]), median_period)


def _walking_s(times: np.ndarray, period: np.ndarray) -> float:
    """Time spent walking: the intervals between steps of one bout (no longer than ``BOUT_GAP_SHARE``
    local periods), and one period for each bout's first step."""
    if len(times) == 0:
        return 0.0
    gaps = np.diff(times)
    in_bout = gaps <= BOUT_GAP_SHARE * period[1:]
    bouts = 1 + np.count_nonzero(~in_bout)
    return float(gaps[in_bout].sum() + bouts * np.median(period))
