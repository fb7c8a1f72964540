"""The few constants of the uncertainty model per checkpoint, read from ``calibration.json`` beside this
module (keyed by checkpoint name) and written only by ``experiments/probe_uncertainty.py``, which
fits them on walker-held-out validation, and, for the default model's speed-scale term and factor,
``experiments/probe_uncertainty_heldout.py`` (walks and places the network never trained on): both
can always remake them.

A checkpoint with no entry of its own borrows the default model's constants, and says so in
``describe``: its uncertainty is then an estimate, not a calibrated one.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

from ftin.files import atomic_write_text

CALIBRATION_FILE = Path(__file__).with_name("calibration.json")
FALLBACK = "ronin_resnet-walking"  # the default model's constants serve a checkpoint without its own


@dataclass(frozen=True)
class Calibration:
    model: str  # the checkpoint these constants were fitted for
    sigma_a: float  # per-window sigma = sigma_a + sigma_b * |v|  (m/s, per horizontal axis)
    sigma_b: float
    scale_sigma: float  # spread of the distance ratio around 1 (RMS of ratio - 1), all carries
    gyro_drift_rad_s: float  # sigma of the yaw drift rate with a gyroscope-only heading (VQF 6-D)
    heading_sigma_rad: float  # sigma of the yaw error with a magnetometer (VQF 9-D)
    position_scale: float = 1.0  # one factor on the whole position covariance, fitted on coverage
    log_std_scale: float | None = None  # for a model with a log-std head: its sigma times this
    # With a head, the factor fitted on the head's sigma is position_scale; this one was fitted on
    # a + b|v|, for a prediction of that model that lacks the head's sigma (a live walk, a restored run).
    position_scale_without_head: float | None = None
    scale_sigma_by_carry: dict[str, float] = field(default_factory=dict)  # where a carry had enough walks
    # The speed scale's spread grows by this times (1 - the walk's direction coherence), in quadrature
    # (``propagate.direction_coherence``): windows that cancel within a second read the distance short.
    coherence_gain: float = 0.0
    fitted_on: str = ""  # what the constants were fitted on, in words

    def scale_sigma_for(self, carry: str | None) -> float:
        """The distance ratio's spread for ``carry`` where it was measured, else all carries'."""
        return self.scale_sigma_by_carry.get(carry or "", self.scale_sigma)

    def without_head(self) -> Calibration:
        """The constants for a prediction without the head's per-window sigma: ``a + b |v|`` and the
        factor fitted with it (the same constants where no head was calibrated)."""
        if self.log_std_scale is None:
            return self
        factor = self.position_scale_without_head
        return replace(
            self,
            log_std_scale=None,
            position_scale=self.position_scale if factor is None else factor,
            position_scale_without_head=None,
        )

    def describe(self, checkpoint: str) -> str:
        """How this uncertainty was calibrated, in one line (the API's ``calibration``)."""
        own = checkpoint == self.model
        head = (
            f"fitted for {self.model} on {self.fitted_on}"
            if own
            else f"not calibrated for {checkpoint}: the constants of {self.model} ({self.fitted_on}) applied"
        )
        drift = math.degrees(self.gyro_drift_rad_s) * 60
        window = (
            f"the model's variance head x{self.log_std_scale:.2f}"
            if self.log_std_scale is not None
            else f"{self.sigma_a:.2f} + {self.sigma_b:.2f}|v| m/s"
        )
        lost = f" (+ {self.coherence_gain:.1f} x (1 - direction coherence))" if self.coherence_gain else ""
        return (
            f"{head}; window sigma {window}, speed scale "
            f"+-{self.scale_sigma:.0%}{lost}, heading drift {drift:.1f} deg/min (6-D) or "
            f"+-{math.degrees(self.heading_sigma_rad):.0f} deg (9-D), covariance x{self.position_scale:.2f} "
            "(experiments/probe_uncertainty.py)"
        )

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


@lru_cache(maxsize=4)
def _table(path: Path = CALIBRATION_FILE) -> dict[str, dict[str, Any]]:
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}


def calibration_for(checkpoint: str) -> Calibration:
    """The constants fitted for ``checkpoint`` (its stem, e.g. ``ronin_resnet-walking``), else the default
    model's without its log-std scale (a scale fitted on one head says nothing of another's: a borrowed
    calibration reads ``a + b |v|``); ``KeyError`` only when the file holds neither."""
    table = _table()
    if checkpoint in table:
        return Calibration(**table[checkpoint])
    return Calibration(**table[FALLBACK]).without_head()


def save_calibration(calibration: Calibration, path: Path = CALIBRATION_FILE) -> None:
    """Write (or replace) ``calibration``'s entry; the probe's only way in."""
    table = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    table[calibration.model] = calibration.to_json()
    atomic_write_text(path, json.dumps(table, indent=1, sort_keys=True) + "\n")
    _table.cache_clear()
