"""Steps and cadence from the accelerometer (and gyroscope), whatever way the phone is carried: one
detector for an uploaded recording, a live phone and the CLI.

``StepDetector(rate_hz)`` is fed samples in time order, in chunks of any size (``update``); ``count``
is the number of steps so far. ``detect_steps(t_s, acc_m_s2, gyro_rad_s)`` runs that same detector
over a whole recording and returns its steps (``Steps``), so a live session ends with exactly the
count an upload of the same samples gives, and at any moment shows the count of the samples so far.

Decisions:
- One pass, causal, with a bounded look-ahead: every decision about a sample depends only on the
  samples up to a few seconds after it, taken from the sample index (never from how they arrived).
  Steps whose look-ahead has arrived are final (``committed``); ``count`` adds the steps that ending
  the recording now would give (the same code run on a copy, so the live count equals the batch
  count of the samples so far, and converges to it whatever the chunking).
- The signal is the norm of the specific force: it needs no orientation (to first order it is the
  vertical acceleration plus g), so a hand, a pocket, a swinging arm or a bag give the same kind of
  signal. It is band-passed (``BAND_HZ``: slow walks step at 1 Hz, runs at up to 3.5 Hz) by a causal
  Butterworth filter (a delay of a fraction of a step: it shifts step times, not counts).
- The step period is read every ``HOP_S`` from the autocorrelation over the last ``WINDOW_S``: the
  first peak nearly as strong as the best (``MULTIPLE_SHARE``: two steps correlate as well as one)
  between ``MIN_PERIOD_S`` and ``MAX_STRIDE_S``; a peak at half of it that is fairly strong
  (``HALF_LAG_SHARE``) is the step and the first one a stride; a period longer than any step
  (``MAX_PERIOD_S``) is a stride whose two steps differ (a pocket, an AR walk) and is halved. Each
  sample takes the median period of the window centred nearest to it and its two neighbours.
- A phone on a limb (a pocket on the thigh, a swinging hand, a running hand) turns fast: band-passed
  rotation rate above ``LIMB_GYRO_RAD_S`` (hand-held, texting, phoning and AR walks turn at 0.1-0.7
  rad/s, pockets and swinging arms at 0.7-2, runs at 1.5-3, on the Inria walks). Its specific force
  need not peak at every step (the other leg's heel strike is far from the phone), but its rotation
  repeats once per stride, cleanly: there the step period is half the gyroscope's stride period.
- A window is walking when its autocorrelation peak reaches ``MIN_PERIODICITY`` (a rhythm, not a
  jolt) and its signal moves more than ``MIN_STD_M_S2`` (a still phone has a rhythm of noise only;
  slow hand-held walks move only ~0.1 m/s²).
- Steps are peaks of the filtered signal in walking samples: the highest within ``REFRACTORY_SHARE``
  of the local period either side, with a prominence of ``PROMINENCE_SHARE`` of the window's standard
  deviation, and that far from the previous step (the harmonics of a heel strike, and the second
  bump of a pocket's double peak, fall inside). A gap between two steps of two or three periods
  (``MAX_FILL``) is a step or two whose peak was too weak (a pocket feels the far leg's heel strike
  faintly): they are counted in between. A longer gap is a stop.
- Cadence is steps per minute of walking: the time between the steps of each bout plus one period a
  bout, so standing at the start and end does not lower it.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import butter, sosfilt, sosfilt_zi

BAND_HZ = (0.6, 3.5)
GYRO_BAND_HZ = (0.3, 2.0)  # a limb's rotation: the stride (0.4-1.8 Hz), not the step's jolts
MIN_PERIOD_S = 0.28  # 214 steps/min: running
MAX_PERIOD_S = 1.2  # 50 steps/min: a very slow walk
MAX_STRIDE_S = 2.0  # the longest stride read from the specific force (a window holds two)
STRIDE_RANGE_S = (0.55, 2.4)  # a limb's rotation period: a stride of a run to one of a slow walk
WINDOW_S = 4.0
HOP_S = 0.5
MIN_PERIODICITY = 0.3
MIN_STD_M_S2 = 0.05
HALF_LAG_SHARE = 0.4
MULTIPLE_SHARE = 0.8
LIMB_GYRO_RAD_S = 0.7
REFRACTORY_SHARE = 0.6
PROMINENCE_SHARE = 0.3
MAX_FILL = 3
BOUT_GAP_SHARE = MAX_FILL + 0.5
MIN_SAMPLES = 32
MIN_RATE_HZ = 10.0  # below it the band cannot be filtered (and a step is a sample or two)
BATCH_CHUNK = 1 << 16  # samples fed at a time by ``detect_steps`` (5.5 min at 200 Hz)
WINDOW_BATCH = 256  # windows judged together: fast, and a bounded temporary (~10 MB at 200 Hz)


@dataclass(frozen=True)
class Steps:
    """The steps of one recording: when they fell and the walking time they span."""

    t_s: np.ndarray  # (S,) time of each step
    walking_s: float  # seconds spent walking (between the steps of each bout, plus a period a bout)
    period_s: float | None  # median step period at the steps (None: no walking found)

    @property
    def count(self) -> int:
        return len(self.t_s)

    @property
    def cadence_per_min(self) -> float | None:
        """Steps per minute of walking (None: too few steps to say)."""
        if self.count < 2 or self.walking_s <= 0:
            return None
        return 60.0 * self.count / self.walking_s


@dataclass(frozen=True)
class _Window:
    period: float  # step period, samples (0: not walking)
    std: float  # the filtered signal's standard deviation over the window


def _autocorrelation(x: np.ndarray) -> np.ndarray:
    """Unbiased, normalised autocorrelation of the rows of ``x`` ``(B, c, n)`` (c signals of n samples
    per window), summed over the c signals: ``(B, n)``.

    The power spectrum is ``re² + im²`` (two real products), not ``X * conj(X)``: numpy's complex
    product takes another rounding path for large arrays than for small ones, and a window's figures
    must not depend on how many windows are computed together (a live phone's chunks against an
    upload's whole recording); the real ufuncs and the FFT give each row the same bits either way.
    """
    x = x - x.mean(axis=2, keepdims=True)
    energy = np.sum(np.sum(x * x, axis=2), axis=1)  # (B,)
    n = x.shape[2]
    spectrum = np.fft.rfft(x, 2 * n, axis=2)
    power = spectrum.real * spectrum.real + spectrum.imag * spectrum.imag
    ac = np.fft.irfft(power, 2 * n, axis=2)[:, :, :n].sum(axis=1)
    quiet = energy <= 0.0
    safe = np.where(quiet, 1.0, energy)
    ac = ac / safe[:, None] * n / np.maximum(n - np.arange(n), 1)  # unbiased: long lags are not shrunk
    ac[quiet] = 0.0
    return ac


def _peaks(ac: np.ndarray, lo: int, hi: int) -> tuple[np.ndarray, int]:
    """``(mask (B, hi' - lo + 1), lo)``: local maxima of each row of ``ac`` at lags ``lo..hi'``
    (``hi'``: ``hi`` clipped to the rows' length); an empty mask when the range is too short."""
    hi = min(hi, ac.shape[1] - 2)
    if hi <= lo + 2:
        return np.zeros((len(ac), 0), dtype=bool), lo
    mid = ac[:, lo : hi + 1]
    return (mid > ac[:, lo - 1 : hi]) & (mid >= ac[:, lo + 1 : hi + 2]), lo


def _first_strong(ac: np.ndarray, mask: np.ndarray, lo: int) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the first peak nearly as strong as the strongest (``MULTIPLE_SHARE``: two steps or
    strides correlate as well as one) and whether the row has a peak at all."""
    values = ac[:, lo : lo + mask.shape[1]]
    best_value = np.where(mask, values, -np.inf).max(axis=1, initial=-np.inf)
    strong = mask & (values >= MULTIPLE_SHARE * best_value[:, None])
    # no peak strong enough (a negative best): the first peak
    pick = np.where(strong.any(axis=1), strong.argmax(axis=1), mask.argmax(axis=1))
    return lo + pick, mask.any(axis=1)


def _step_periods(ac: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``(step period in samples, autocorrelation at it)`` of windows of the filtered norm (rows of
    ``ac``); 0, 0 where there is no peak."""
    mask, lo = _peaks(ac, max(int(MIN_PERIOD_S * rate_hz), 1), int(MAX_STRIDE_S * rate_hz) + 1)
    rows = np.arange(len(ac))
    best, found = _first_strong(ac, mask, lo)
    # A stride (two steps) may correlate more than a step: prefer half of it when it is nearly as strong.
    lags = lo + np.arange(mask.shape[1])
    near_half = mask & (np.abs(lags[None, :] - best[:, None] / 2) <= 0.15 * best[:, None])
    values = np.where(near_half, ac[:, lo : lo + mask.shape[1]], -np.inf)
    candidate = lo + values.argmax(axis=1)  # the strongest, the first of equals
    take = near_half.any(axis=1) & (
        ac[rows, candidate] >= np.maximum(HALF_LAG_SHARE * ac[rows, best], MIN_PERIODICITY)
    )
    best = np.where(take, candidate, best)
    strength = ac[rows, best]
    # too slow for a step: a stride whose steps differ (a pocket)
    period = np.where(best > MAX_PERIOD_S * rate_hz, best / 2.0, best.astype(np.float64))
    return np.where(found, period, 0.0), np.where(found, strength, 0.0)


def _stride_periods(ac: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``(stride period in samples, autocorrelation at it)`` of windows of the filtered gyroscope."""
    mask, lo = _peaks(ac, int(STRIDE_RANGE_S[0] * rate_hz), int(STRIDE_RANGE_S[1] * rate_hz) + 1)
    best, found = _first_strong(ac, mask, lo)
    strength = ac[np.arange(len(ac)), best]
    return np.where(found, best.astype(np.float64), 0.0), np.where(found, strength, 0.0)


def _median(values: list[float]) -> float:
    """The median of a few numbers (as ``np.median``: the mean of the middle two of an even count)."""
    ordered = sorted(values)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2.0


class StepDetector:
    """Steps of samples fed in time order at ``rate_hz`` (module docstring); any chunking gives the
    same steps. Memory is bounded: only the last window of samples is kept."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = float(rate_hz)
        self.usable = self.rate_hz >= MIN_RATE_HZ
        nyquist_share = 0.45 * self.rate_hz
        self._sos = butter(
            2, [BAND_HZ[0], min(BAND_HZ[1], nyquist_share)], btype="band", fs=rate_hz, output="sos"
        )
        self._gyro_sos = butter(
            2, [GYRO_BAND_HZ[0], min(GYRO_BAND_HZ[1], nyquist_share)], btype="band", fs=rate_hz, output="sos"
        )
        self._width = max(int(round(WINDOW_S * self.rate_hz)), MIN_SAMPLES)
        self._hop = max(int(round(HOP_S * self.rate_hz)), 1)
        self._zi: np.ndarray | None = None
        self._gyro_zi: np.ndarray | None = None
        self._start = 0  # absolute index of the first kept sample
        self._t = np.zeros(0)
        self._x = np.zeros(0)  # filtered norm of the kept samples
        self._g = np.zeros((0, 3))  # filtered gyroscope of the kept samples (zeros without one)
        self._has_gyro = True
        self._windows: list[_Window] = []  # window k covers samples [k hop, k hop + width)
        self._first_window = 0  # index of self._windows[0]
        self._scan = 0  # the first sample not yet judged as a step
        self._last_step = -1  # absolute index of the last peak found (not of filled steps)
        self._last_step_s = 0.0  # and its time
        self.committed: list[float] = []  # times of the final steps
        self._periods: list[float] = []  # step period (samples) at each final step
        self._pending_tail: Steps | None = None

    # --- input -----------------------------------------------------------------------------------

    def update(self, t_s: np.ndarray, acc_m_s2: np.ndarray, gyro_rad_s: np.ndarray | None = None) -> None:
        """Take samples ``(n,)`` s, ``(n, 3)`` m/s² (and rad/s) in time order (``count``: the steps)."""
        self._pending_tail = None
        if not self.usable or len(t_s) == 0:
            return
        norm = np.linalg.norm(np.asarray(acc_m_s2, dtype=np.float64), axis=1)
        if gyro_rad_s is None:
            self._has_gyro = False
            gyro = np.zeros((len(norm), 3))
        else:  # a missing rotation rate turns nothing
            gyro = np.nan_to_num(np.asarray(gyro_rad_s, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        if self._zi is None:  # start the filters as if the first sample had always been there
            self._zi = sosfilt_zi(self._sos) * norm[0]
            self._gyro_zi = sosfilt_zi(self._gyro_sos)[:, :, None] * gyro[0]
        x, self._zi = sosfilt(self._sos, norm, zi=self._zi)
        g, self._gyro_zi = sosfilt(self._gyro_sos, gyro, axis=0, zi=self._gyro_zi)
        self._t = np.concatenate([self._t, np.asarray(t_s, dtype=np.float64)])
        self._x = np.concatenate([self._x, x])
        self._g = np.concatenate([self._g, g])
        self._add_windows()
        self._judge(final=False)
        self._trim()

    @property
    def count(self) -> int:
        """Steps so far: the final ones and those the samples so far give if they end here (computed
        when asked, once per update: a copy of the last few seconds judged to their end)."""
        return len(self.committed) + self.tail().count

    def tail(self) -> Steps:
        """The steps not yet final, as if the recording ended now (the detector is not changed)."""
        if self._pending_tail is None:
            ending = copy.deepcopy(self)
            before = len(ending.committed)
            ending._judge(final=True)
            times = np.asarray(ending.committed[before:])
            self._pending_tail = Steps(times, 0.0, None)
        return self._pending_tail

    def finish(self) -> Steps:
        """All the steps, the recording having ended (no more samples may follow)."""
        self._judge(final=True)
        self._pending_tail = Steps(np.zeros(0), 0.0, None)
        times, periods = np.asarray(self.committed), np.asarray(self._periods) / self.rate_hz
        median = float(np.median(periods)) if len(periods) else None
        return Steps(times, _walking_s(times, periods), median)

    # --- the detector ----------------------------------------------------------------------------

    @property
    def _end(self) -> int:
        return self._start + len(self._x)

    def _add_windows(self) -> None:
        """Judge every window whose samples have all arrived, ``WINDOW_BATCH`` at a time (numpy over
        many windows at once: an hour's 7,200 windows take a fraction of a second)."""
        first = self._first_window + len(self._windows)
        count = (self._end - self._width) // self._hop - first + 1
        for k in range(first, first + max(count, 0), WINDOW_BATCH):
            a = k * self._hop - self._start
            n = min(WINDOW_BATCH, first + count - k)
            self._windows.extend(self._judge_windows(a, n, self._width, self._hop))

    def _judge_windows(self, a: int, count: int, width: int, hop: int) -> list[_Window]:
        """The ``count`` windows of ``width`` kept samples starting at kept index ``a``, ``hop`` apart."""
        span = slice(a, a + (count - 1) * hop + width)
        x = sliding_window_view(self._x[span], width)[::hop]  # (count, width), views
        std = x.std(axis=1)
        period = np.zeros(count)
        moving = np.flatnonzero(std >= MIN_STD_M_S2)
        if len(moving):
            limb = np.zeros(len(moving), dtype=bool)
            if self._has_gyro:
                g = sliding_window_view(self._g[span], width, axis=0)[::hop][moving]  # (m, 3, width)
                limb = np.sqrt(np.mean(np.sum(g * g, axis=1), axis=1)) >= LIMB_GYRO_RAD_S
            if limb.any():
                stride, strength = _stride_periods(_autocorrelation(g[limb]), self.rate_hz)
                period[moving[limb]] = np.where(strength >= MIN_PERIODICITY, stride / 2.0, 0.0)
            if not limb.all():
                steps = moving[~limb]
                step, strength = _step_periods(_autocorrelation(x[steps][:, None, :]), self.rate_hz)
                period[steps] = np.where(strength >= MIN_PERIODICITY, step, 0.0)
        return [_Window(float(p), float(s)) for p, s in zip(period, std, strict=True)]

    def _window_of(self, i: int, final: bool) -> _Window | None:
        """The window centred nearest to sample ``i``, its period the median of its walking
        neighbours' (one odd window, a stride read as a step, is outvoted); None: not known yet."""
        k = max(int(np.floor((i - self._width // 2) / self._hop + 0.5)), 0)
        last = self._first_window + len(self._windows) - 1
        if k + 1 > last and not (final and self._windows):
            return None
        k = min(k, last)
        window = self._windows[k - self._first_window]
        if window.period == 0:
            return window
        near = self._windows[max(k - 1 - self._first_window, 0) : k + 2 - self._first_window]
        return _Window(_median([w.period for w in near if w.period > 0]), window.std)

    def _judge(self, final: bool) -> None:
        """Find the steps among the samples whose look-ahead has arrived (all of them at the end)."""
        if final and not self._windows and len(self._x) >= MIN_SAMPLES:
            self._windows.extend(self._judge_windows(0, 1, len(self._x), 1))  # shorter than one window
        x, start, end = self._x, self._start, self._end
        reach = int(REFRACTORY_SHARE * MAX_PERIOD_S * self.rate_hz) + 1
        lo = max(self._scan, start + 1)
        j = np.arange(lo, end - 1) - start
        self._scan = max(end - 1, lo)  # where the scan stops unless a candidate waits
        for i in (lo + np.flatnonzero((x[j] > x[j - 1]) & (x[j] >= x[j + 1]))).tolist():
            window = self._window_of(i, final)
            if window is None or (not final and i + reach >= end):
                self._scan = i  # judged once its window and look-ahead have arrived
                return
            r = int(REFRACTORY_SHARE * window.period)
            if final and i + r >= end:
                return  # a peak needs its refractory span on both sides: the ends of a recording
            if i >= r and window.period > 0 and self._is_step(i - start, r, window):  # are the phone
                self._add_step(i, window.period)  # being taken out or put away, the filter settling

    def _is_step(self, j: int, r: int, window: _Window) -> bool:
        """Is the local maximum at kept index ``j`` the highest and prominent within ``r`` samples?"""
        x = self._x
        left, right = x[max(j - r, 0) : j], x[j + 1 : j + r + 1]
        if (len(left) and left.max() >= x[j]) or (len(right) and right.max() > x[j]):
            return False
        floor = max(left.min() if len(left) else x[j], right.min() if len(right) else x[j])
        if x[j] - floor < PROMINENCE_SHARE * window.std:
            return False
        return self._last_step < 0 or j + self._start - self._last_step >= r

    def _add_step(self, i: int, period: float) -> None:
        if self._last_step >= 0:
            gap = (i - self._last_step) / period
            missed = int(round(gap)) - 1
            if 1 <= missed < MAX_FILL and gap <= BOUT_GAP_SHARE:  # weak peaks, not a stop
                t0, t1 = self._last_step_s, float(self._t[i - self._start])
                for m in range(1, missed + 1):
                    self.committed.append(float(t0 + (t1 - t0) * m / (missed + 1)))
                    self._periods.append(period)
        self._last_step, self._last_step_s = i, float(self._t[i - self._start])
        self.committed.append(self._last_step_s)
        self._periods.append(period)

    def _trim(self) -> None:
        """Forget the samples no later decision reads: before the next window and the step scan."""
        next_window = (self._first_window + len(self._windows)) * self._hop
        reach = int(REFRACTORY_SHARE * MAX_PERIOD_S * self.rate_hz) + 2
        keep_from = min(next_window, self._scan - reach)
        drop = keep_from - self._start
        if drop > 0:
            self._t, self._x, self._g = self._t[drop:], self._x[drop:], self._g[drop:]
            self._start = keep_from
        # windows no sample still to judge will read (keep the last: the end uses it)
        first_needed = max(int(np.floor((self._scan - self._width // 2) / self._hop + 0.5)) - 1, 0)
        extra = min(first_needed - self._first_window, len(self._windows) - 1)
        if extra > 0:
            del self._windows[:extra]
            self._first_window += extra


def _walking_s(times: np.ndarray, period_s: np.ndarray) -> float:
    """Time spent walking: the intervals between steps of one bout (no longer than ``BOUT_GAP_SHARE``
    local periods), and one period for each bout's first step."""
    if len(times) == 0:
        return 0.0
    gaps = np.diff(times)
    in_bout = gaps <= BOUT_GAP_SHARE * period_s[1:]
    bouts = 1 + np.count_nonzero(~in_bout)
    return float(gaps[in_bout].sum() + bouts * np.median(period_s))


def sample_rate_hz(t_s: np.ndarray) -> float:
    """The rate of a uniform grid of times, rounded (to 1 mHz) so that a grid built at a given rate
    gives that rate back exactly."""
    return round(1.0 / float(np.median(np.diff(t_s))), 3)


def detect_steps(t_s: np.ndarray, acc_m_s2: np.ndarray, gyro_rad_s: np.ndarray | None = None) -> Steps:
    """The steps in a recording's specific force (``(N, 3)`` m/s², any device frame, a uniform time
    grid); the gyroscope (``(N, 3)`` rad/s), when given, tells a phone on a limb (module docstring)."""
    t = np.asarray(t_s, dtype=np.float64)
    if len(t) < MIN_SAMPLES or not np.all(np.diff(t) > 0):
        return Steps(np.empty(0), 0.0, None)  # too short or unordered
    detector = StepDetector(sample_rate_hz(t))
    # In chunks (any chunking gives the same steps): the filtered copies of an hour at 200 Hz would
    # be ~80 MB at once, a chunk's are a few.
    for a in range(0, len(t), BATCH_CHUNK):
        b = a + BATCH_CHUNK
        detector.update(t[a:b], acc_m_s2[a:b], None if gyro_rad_s is None else gyro_rad_s[a:b])
    return detector.finish()
