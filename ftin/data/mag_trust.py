"""Magnetometer trust per stretch: which stretches of a walk took their heading from the field.

A walk indoors passes steel and wiring: the field is the Earth's in some places and something else in
others. Where ``auto`` chose VQF 9-D (``ftin.data.orientation_choice``), the heading comes from VQF's
own disturbance rejection: VQF compares every sample's field norm and dip with the reference it learnt
from the clean field (``magNormTh`` 10 %, ``magDipTh`` 10 deg) and, where they leave it, holds the
gyroscope's heading instead of the field's (for at most ``magMaxRejectionTime``, 60 s, after which it
takes the new field as its reference).

Each ``STRETCH_S`` stretch says what its heading used (:class:`Stretch`): ``vqf`` where VQF took the
field, ``vqf6d`` where VQF rejected it over most of the stretch (the gyroscope's relative heading
carried through, as 6-D would), with the stretch's median field norm and dip beside the walk's clean
reference (the median over the stretches VQF took) in words. The orientation is exactly VQF 9-D's.

Measured and not adopted (``experiments/probe_mag_trust.py``, its report
``docs/results/probes/mag_trust.md``; docs/orientation.md):

* holding VQF's rejection for the whole walk (``HOLD_PARAMS``): better on the training walks (median
  heading 8.9 -> 8.2 / 3.3 -> 3.0 / 1.1 -> 1.1 deg) and on the floor walks after minute 2, but Inria's
  held-out ``Dist`` walks 1.4 deg worse and the floor walks' ATE 5.1 % worse: the adoption rule fails;
* a test of our own per stretch (norm and dip against the walk's quietest stretches, the field's
  heading spread in 6-D's world and its residual against the neighbouring stretches, as MiHDE and
  Ettlinger et al., NAVIGATION 2024, test a quasi-static field), carrying 6-D's heading through the
  stretches it failed: its interpolation through 6-D lost where the gyroscope's heading drifts (an
  OxIOD hand-held training walk 9.4 -> 65 deg).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from vqf import offlineVQF

from ftin.data import frames
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence

STRETCH_S = 5.0
REJECTED_FRACTION = 0.5  # of a stretch's samples VQF flags: its heading there is the gyroscope's
MIN_STRETCHES = 2  # a shorter recording is judged as a whole (``ftin.data.orientation_choice``)
# VQF's own options for the 9-D run: its defaults. Holding the rejection for a whole walk
# (``HOLD_PARAMS``) was measured and not adopted (module docstring).
VQF_PARAMS: dict[str, float] = {}
HOLD_PARAMS: dict[str, float] = {"magMaxRejectionTime": 600.0}
DEFAULT_MAX_REJECTION_S = 60.0  # VQF's magMaxRejectionTime

VQF9D, VQF6D = "vqf", "vqf6d"


@dataclass(frozen=True)
class Stretch:
    """One stretch of the walk and what its heading used (``source``: ``vqf`` or ``vqf6d``) and why."""

    t0_s: float
    t1_s: float
    source: str
    reason: str

    def to_json(self) -> dict[str, Any]:
        return {
            "t0_s": round(self.t0_s, 3),
            "t1_s": round(self.t1_s, 3),
            "source": self.source,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class MagTrust:
    """The stretches (consecutive ones with the same source merged) and the share of the walk whose
    field VQF took (``clean_fraction``), against the walk's clean reference norm and dip."""

    stretches: list[Stretch]
    clean_fraction: float
    reference_norm_uT: float | None
    reference_dip_deg: float | None

    @property
    def source(self) -> str:
        """``vqf`` where any stretch took the field, else ``vqf6d``."""
        return VQF9D if any(s.source == VQF9D for s in self.stretches) else VQF6D

    def summary(self) -> str:
        took = f"VQF 9-D took the field in {self.clean_fraction:.0%} of the walk"
        if self.reference_norm_uT is not None:
            took += f" (clean: {self.reference_norm_uT:.0f} µT, dip {self.reference_dip_deg:.0f} deg)"
        runs = f"{len(self.stretches)} run{'s' if len(self.stretches) != 1 else ''}"
        return f"{took} and held the gyroscope's heading where the field left its reference ({runs})"


def assess(
    t_s: np.ndarray,
    mag_uT: np.ndarray,
    q_world_device_wxyz: np.ndarray,
    disturbed: np.ndarray,
    max_rejection_s: float = DEFAULT_MAX_REJECTION_S,
) -> MagTrust | None:
    """The stretches of a walk from VQF 9-D's orientation and its per-sample disturbance flags
    (``magDistDetected``), a flagged sample more than ``max_rejection_s`` into its flagged run counted
    as taken (VQF's rejection gives up there); None for a recording shorter than ``MIN_STRETCHES``
    stretches."""
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    size = int(round(STRETCH_S / dt)) if dt > 0 else 0
    if size < 2 or len(t) < MIN_STRETCHES * size:
        return None
    mag = np.asarray(mag_uT, dtype=np.float64)
    norm = np.linalg.norm(mag, axis=1)
    up = frames.rotation_from_wxyz(q_world_device_wxyz).apply(mag)[:, 2]
    dip = np.degrees(np.arcsin(np.clip(-up / np.maximum(norm, 1e-9), -1.0, 1.0)))
    flags = np.asarray(disturbed, dtype=bool)
    run_start = np.maximum.accumulate(np.where(flags, 0, np.arange(len(t))))  # last unflagged sample
    gave_up = flags & (t - t[run_start] > max_rejection_s)
    rejected = flags & ~gave_up
    bounds = _stretch_bounds(len(t), size)
    took = np.array([np.mean(rejected[a:b]) < REJECTED_FRACTION for a, b in bounds])
    late = np.array([np.mean(gave_up[a:b]) >= REJECTED_FRACTION for a, b in bounds])
    ref_norm = ref_dip = None
    clean = took & ~late
    if clean.any():
        inside = np.concatenate([np.arange(a, b) for (a, b), k in zip(bounds, clean, strict=True) if k])
        ref_norm, ref_dip = float(np.median(norm[inside])), float(np.median(dip[inside]))
    texts = []
    for (a, b), k, given_up in zip(bounds, took, late, strict=True):
        field = f"field {np.median(norm[a:b]):.0f} µT, dip {np.median(dip[a:b]):.0f} deg"
        if given_up:
            texts.append(
                f"{field}, disturbed for over {max_rejection_s:.0f} s: VQF 9-D takes the field again "
                "(its rejection gives up)"
            )
        elif k:
            texts.append("field clean: heading from the magnetometer (VQF 9-D)")
        elif ref_norm is None:
            texts.append(
                f"{field}, disturbed throughout: heading from the gyroscope (VQF rejected the field)"
            )
        else:
            texts.append(
                f"{field} against the clean {ref_norm:.0f} µT, {ref_dip:.0f} deg: heading from the gyroscope "
                "(VQF rejected the field)"
            )
    clean_fraction = float(sum(b - a for (a, b), k in zip(bounds, took, strict=True) if k) / len(t))
    kinds = ["given up" if g else "clean" if k else "rejected" for k, g in zip(took, late, strict=True)]
    stretches = _merged(t, bounds, kinds, [VQF9D if k else VQF6D for k in took], texts)
    return MagTrust(stretches, clean_fraction, ref_norm, ref_dip)


def oriented(seq: ImuSequence, params: dict[str, float] | None = None) -> tuple[ImuSequence, MagTrust | None]:
    """``seq`` oriented by VQF 9-D with ``params`` (None: ``VQF_PARAMS``; its notes, its ground truth
    turned into the estimate's world at the start) and the stretches' verdicts (None for a short
    recording): exactly what ``estimate_orientation`` gives, with what each stretch took said."""
    params = dict(VQF_PARAMS if params is None else params)
    if seq.mag_uT is None or not np.isfinite(seq.mag_uT).all():  # estimate_orientation runs 6-D then
        return estimate_orientation(seq, use_magnetometer=True), None
    out = estimate_orientation(seq, use_magnetometer=True, **params)
    flags = offlineVQF(
        np.ascontiguousarray(seq.gyro_rad_s, dtype=np.float64),
        np.ascontiguousarray(seq.acc_m_s2, dtype=np.float64),
        np.ascontiguousarray(seq.mag_uT, dtype=np.float64),
        float(np.median(np.diff(seq.t_s))),
        params or None,
    )["magDistDetected"]
    limit = params.get("magMaxRejectionTime", DEFAULT_MAX_REJECTION_S)
    return out, assess(seq.t_s, seq.mag_uT, out.q_world_device_wxyz, flags, limit)


def _stretch_bounds(n: int, size: int) -> list[tuple[int, int]]:
    """``[a, b)`` ranges of ``size`` samples; a last piece under half a stretch joins the one before."""
    bounds = [(a, min(a + size, n)) for a in range(0, n, size)]
    if len(bounds) > 1 and bounds[-1][1] - bounds[-1][0] < size // 2:
        bounds[-2:] = [(bounds[-2][0], n)]
    return bounds


def _merged(
    t: np.ndarray, bounds: list[tuple[int, int]], kinds: list[str], sources: list[str], texts: list[str]
) -> list[Stretch]:
    """Consecutive stretches of the same kind (clean, rejected, given up) merged; a merged run keeps its
    first reason, and a gyroscope run counts the stretches after it."""
    found: list[Stretch] = []
    count, last_kind = 0, None
    for (a, b), kind, source, text in zip(bounds, kinds, sources, texts, strict=True):
        if found and kind == last_kind:
            found[-1] = Stretch(found[-1].t0_s, float(t[b - 1]), source, found[-1].reason)
            count += 1
            continue
        _note_more(found, count)
        found.append(Stretch(float(t[a]), float(t[b - 1]), source, text))
        count, last_kind = 0, kind
    _note_more(found, count)
    return found


def _note_more(found: list[Stretch], count: int) -> None:
    if found and found[-1].source == VQF6D and count:
        last = found[-1]
        found[-1] = Stretch(
            last.t0_s,
            last.t1_s,
            last.source,
            f"{last.reason}; {count} more {'stretch' if count == 1 else 'stretches'} alike",
        )
