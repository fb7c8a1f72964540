"""What a simulated walk looks like: carry mode, duration, rate, seed, walking plan and sensor noise.

Decisions recorded here:
- One seed drives everything, through two independent child streams (``numpy.random.SeedSequence
  .spawn``): one for the motion (walker, carry pose, plan), one for the sensor noise. Switching the
  noise off or changing its parameters therefore never changes the motion or ground truth.
- The motion does not depend on ``rate_hz`` either: it is defined on a fixed 100 Hz spline grid and
  only *sampled* at ``rate_hz`` (see ``ftin.sim.trajectory``), so a 100 Hz and a 200 Hz simulation
  with the same seed describe the same walk.
- Noise defaults are typical of a phone MEMS IMU (BMI160 / ICM-20x class, slightly worse than the
  datasheets, as phones are): white noise density, a per-sequence constant bias and a small bias
  random walk. ``noise=None`` gives the exact, noiseless IMU.
"""

from __future__ import annotations

import enum
import math
import numbers
from dataclasses import dataclass, field


class CarryMode(str, enum.Enum):
    """How the phone is carried; each mode has its own mounting and gait coupling (``ftin.sim.carry``)."""

    HANDHELD = "handheld"  # held in front, screen up and tilted towards the face
    POCKET = "pocket"  # front trouser pocket: swings with the thigh
    TROLLEY = "trolley"  # lying on a pushed trolley: almost no bounce


@dataclass(frozen=True)
class ImuNoise:
    """Sensor error model, per axis, in continuous-time units (converted with the sample rate).

    Sampled as ideal white noise (no anti-alias filter): the discrete standard deviation is
    ``density * sqrt(rate_hz)``. The bias is ``constant + random walk``: the constant part is drawn
    once per sequence from N(0, bias_std²), the walk adds N(0, rw² dt) per sample.
    """

    gyro_noise_density_rad_s_sqrt_hz: float = 2.0e-4  # ~0.011 deg/s/sqrt(Hz)
    acc_noise_density_m_s2_sqrt_hz: float = 2.0e-3  # ~200 micro-g/sqrt(Hz)
    gyro_bias_std_rad_s: float = 5.0e-3  # ~0.3 deg/s turn-on bias
    acc_bias_std_m_s2: float = 5.0e-2  # ~5 mg
    gyro_bias_random_walk_rad_s_sqrt_s: float = 2.0e-5
    acc_bias_random_walk_m_s2_sqrt_s: float = 3.0e-4

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"ImuNoise.{name} must be a finite number >= 0, got {value!r}")

    def as_meta(self) -> dict[str, float]:
        return dict(vars(self))


def _check_range(name: str, value: tuple[float, float], low: float) -> tuple[float, float]:
    lo, hi = (float(v) for v in value)
    if not (low <= lo <= hi and math.isfinite(hi)):
        raise ValueError(f"SimConfig.{name} must be (min, max) with {low} <= min <= max, got {value!r}")
    return lo, hi


@dataclass(frozen=True)
class SimConfig:
    """One simulated pedestrian walk. ``simulate(SimConfig(...))`` turns it into an ``ImuSequence``.

    The walk is a random plan (from ``seed``): the walker stands for ``rest_start_s``, then walks legs
    of ``leg_duration_range_s`` at speeds from ``speed_range_m_s``; within a leg it turns with
    ``turn_probability`` (by an angle from ``turn_angle_range_deg``, at a mean rate from
    ``turn_rate_range_deg_s``); between legs it stops with ``stop_probability`` (for
    ``stop_duration_range_s``), or else changes speed; it ends standing for at least ``rest_end_s``.
    """

    duration_s: float = 60.0
    rate_hz: float = 100.0
    carry: CarryMode = CarryMode.HANDHELD
    seed: int = 0
    noise: ImuNoise | None = field(default_factory=ImuNoise)  # None: exact, noiseless IMU
    name: str | None = None  # default: "sim_<carry>_<seed>"
    speed_range_m_s: tuple[float, float] = (0.8, 1.6)
    leg_duration_range_s: tuple[float, float] = (4.0, 12.0)
    turn_probability: float = 0.6
    turn_angle_range_deg: tuple[float, float] = (30.0, 150.0)
    turn_rate_range_deg_s: tuple[float, float] = (30.0, 60.0)  # mean; the peak is 2.2x
    stop_probability: float = 0.2
    stop_duration_range_s: tuple[float, float] = (1.5, 5.0)
    rest_start_s: float = 2.0
    rest_end_s: float = 1.0

    def __post_init__(self) -> None:
        # Accept the plain string ("pocket") too: CLI options and JSON configs arrive as strings.
        try:
            object.__setattr__(self, "carry", CarryMode(self.carry))
        except ValueError:
            valid = ", ".join(m.value for m in CarryMode)
            raise ValueError(f"SimConfig.carry must be one of {valid}, got {self.carry!r}") from None
        for name in ("duration_s", "rate_hz"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"SimConfig.{name} must be a finite number > 0, got {value!r}")
        if self.duration_s * self.rate_hz < 2:
            raise ValueError(
                f"SimConfig.duration_s * rate_hz must give at least 2 samples, got "
                f"{self.duration_s} s at {self.rate_hz} Hz"
            )
        for name in ("rest_start_s", "rest_end_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"SimConfig.{name} must be a finite number >= 0, got {value!r}")
        for name in ("turn_probability", "stop_probability"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"SimConfig.{name} must lie in [0, 1], got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, numbers.Integral) or self.seed < 0:
            raise ValueError(f"SimConfig.seed must be an int >= 0, got {self.seed!r}")
        if self.noise is not None and not isinstance(self.noise, ImuNoise):
            raise ValueError(f"SimConfig.noise must be an ImuNoise or None, got {type(self.noise).__name__}")
        lows = {
            "speed_range_m_s": 0.1,
            "leg_duration_range_s": 0.5,
            "turn_angle_range_deg": 0.0,
            "turn_rate_range_deg_s": 1.0,
            "stop_duration_range_s": 0.0,
        }
        for name, low in lows.items():
            object.__setattr__(self, name, _check_range(name, getattr(self, name), low))

    @property
    def sequence_name(self) -> str:
        return self.name if self.name is not None else f"sim_{self.carry.value}_{self.seed}"

    @property
    def n_samples(self) -> int:
        """Samples at ``t_s = i / rate_hz`` for i in [0, n): the duration rounded to whole samples."""
        return int(round(self.duration_s * self.rate_hz))
