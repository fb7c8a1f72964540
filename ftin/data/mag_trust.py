"""Magnetometer trust per stretch: heading from the field only where the field is clean.

A walk indoors passes steel and wiring: the field is the Earth's in some places and something else in
others. Trusting it for the whole walk (VQF 9-D) turns the heading wherever it is disturbed; dropping
it (VQF 6-D) lets the gyroscope's heading drift for minutes. Here the walk is cut into ``STRETCH_S``
stretches and each is tested against the walk's own clean reference, as MiHDE and Ettlinger et al.
(NAVIGATION 2024) test a quasi-static field:

* **norm**: the stretch's median field norm within ``NORM_TOLERANCE`` of the reference norm;
* **dip**: its median inclination (angle of the field below the horizontal) within ``DIP_TOLERANCE_DEG``
  of the reference dip;
* **turning**: the field's heading in VQF 6-D's world (where the gyroscope holds the heading over
  seconds) spreads by at most ``SPREAD_TOLERANCE_DEG`` within the stretch;
* **residual**: that heading, the stretch's median, within ``RESIDUAL_TOLERANCE_DEG`` of the median of
  the other candidate stretches within ``NEIGHBOURS_S`` (6-D's drift is slow; a field turned by a
  steady local disturbance is not).

The reference (norm and dip) is the median over the quietest third of the stretches (the smallest
spread of the field's heading and norm), so a walk clean half of the time finds it. The heading then
follows the field where it is clean and 6-D's relative heading through the rest: the correction from
6-D's world to magnetic north, measured in every clean stretch (its median), is interpolated linearly
between clean stretches (held before the first and after the last), so the heading never jumps at a
border. With fewer than ``MIN_CLEAN_FRACTION`` of the stretches clean the walk runs as 6-D.

VQF's own rejection (``magDistRejectionEnabled``, on by default) already holds the gyroscope's heading
through a disturbance it detects against a reference it keeps learning, for at most
``magMaxRejectionTime`` (60 s) before it takes the new field as the reference: on a floor disturbed
for minutes it accepts the disturbed field (``experiments/probe_mag_trust.py`` measures its options
against this module). :func:`assess` is pure: arrays in, :class:`MagTrust` out;
``ftin.data.orientation_option`` applies it where ``auto`` chose VQF 9-D.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from vqf import offlineVQF

from ftin.data import frames
from ftin.data.mag_calibration import EARTH_FIELD_UT
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence

STRETCH_S = 5.0
NORM_TOLERANCE = 0.15  # relative to the reference norm
DIP_TOLERANCE_DEG = 10.0
SPREAD_TOLERANCE_DEG = 35.0  # the field's heading within a stretch, robust spread (1.4826 MAD)
RESIDUAL_TOLERANCE_DEG = 20.0
NEIGHBOURS_S = 30.0
QUIET_FRACTION = 1 / 3
MIN_CLEAN_FRACTION = 0.2
REJECTED_FRACTION = 0.5  # of a stretch's samples VQF flags itself: it holds the heading there already
# Below the clean fraction a walk runs as 6-D only where 6-D holds: a gyroscope whose heading turns
# faster than this against the field keeps VQF 9-D (its own rejection) rather than drift for minutes.
MAX_GYRO_DRIFT_DEG_MIN = 10.0
ALIGN_WINDOW_S = 2.0  # as ``estimate_orientation`` aligns the truth
MARGIN_S = 10.0  # of clean field beside a 6-D stretch not used for the heading correction
MIN_STRETCHES = 3  # a shorter recording is judged as a whole (``ftin.data.orientation_choice``)

VQF9D, VQF6D = "vqf", "vqf6d"
# VQF's own options for the 9-D run: hold the rejection for a whole walk (its default takes a disturbed
# field as the new reference after 60 s: an office floor disturbed for minutes turned its heading).
VQF_PARAMS: dict[str, float] = {"magMaxRejectionTime": 600.0}


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
    """The stretches (consecutive ones with the same verdict merged), the orientation whose heading
    follows the field where it is clean (``q_world_device_wxyz``, in VQF 9-D's world: magnetic north),
    VQF 9-D's own (``q9_wxyz``), and the reference the field was judged against."""

    stretches: list[Stretch]
    q_world_device_wxyz: np.ndarray
    q9_wxyz: np.ndarray
    clean_fraction: float
    reference_norm_uT: float
    reference_dip_deg: float

    @property
    def source(self) -> str:
        """``vqf`` where any stretch took the field, else ``vqf6d``."""
        return VQF9D if any(s.source == VQF9D for s in self.stretches) else VQF6D

    def summary(self) -> str:
        n = len(self.stretches)
        clean = f"the field clean in {self.clean_fraction:.0%} of the walk"
        if self.source == VQF6D:
            return (
                f"{clean} (judged per {STRETCH_S:.0f}-s stretch against its own reference, "
                f"{self.reference_norm_uT:.0f} µT, dip {self.reference_dip_deg:.0f} deg): disturbed "
                "throughout, VQF 6-D (heading from the gyroscope)"
            )
        return (
            f"{clean} (judged per {STRETCH_S:.0f}-s stretch against its own reference, "
            f"{self.reference_norm_uT:.0f} µT, dip {self.reference_dip_deg:.0f} deg): heading from the "
            f"magnetometer (VQF 9-D) where clean, VQF 6-D's relative heading carried through the rest "
            f"({n} stretches)"
        )


def assess(
    t_s: np.ndarray, gyro_rad_s: np.ndarray, acc_m_s2: np.ndarray, mag_uT: np.ndarray
) -> MagTrust | None:
    """The per-stretch verdicts and the heading built from them (module docstring); None for a
    recording shorter than ``MIN_STRETCHES`` stretches."""
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    size = int(round(STRETCH_S / dt)) if dt > 0 else 0
    if size < 2 or len(t) < MIN_STRETCHES * size:
        return None
    mag = np.ascontiguousarray(mag_uT, dtype=np.float64)
    out = offlineVQF(
        np.ascontiguousarray(gyro_rad_s, dtype=np.float64),
        np.ascontiguousarray(acc_m_s2, dtype=np.float64),
        mag,
        dt,
        dict(VQF_PARAMS) or None,
    )
    R6 = frames.rotation_from_wxyz(out["quat6D"])
    m_world = R6.apply(mag)
    norm = np.linalg.norm(mag, axis=1)
    dip = np.degrees(np.arcsin(np.clip(-m_world[:, 2] / np.maximum(norm, 1e-9), -1.0, 1.0)))
    heading = np.degrees(np.unwrap(np.arctan2(m_world[:, 1], m_world[:, 0])))
    bounds = _stretch_bounds(len(t), size)
    norm_k = np.array([np.median(norm[a:b]) for a, b in bounds])
    dip_k = np.array([np.median(dip[a:b]) for a, b in bounds])
    centres = np.array([0.5 * (t[a] + t[b - 1]) for a, b in bounds])
    # A gyroscope bias turns 6-D's world steadily (an iPhone 5's raw gyroscope: degrees a second): the
    # field's heading there is judged after that steady turn is taken out (Theil-Sen, robust to the
    # disturbed stretches).
    raw_heading_k = np.array([np.median(heading[a:b]) for a, b in bounds])
    raw_spread_k = np.array([_robust_spread(heading[a:b]) for a, b in bounds])
    norm_spread_k = np.array([_robust_spread(norm[a:b]) for a, b in bounds]) / max(
        float(np.median(norm)), 1e-9
    )
    quiet_rank = np.argsort(np.argsort(raw_spread_k)) + np.argsort(np.argsort(norm_spread_k))
    quiet = np.argsort(quiet_rank, kind="stable")[: max(1, int(np.ceil(QUIET_FRACTION * len(bounds))))]
    ref_norm, ref_dip = float(np.median(norm_k[quiet])), float(np.median(dip_k[quiet]))
    earthlike = (np.abs(norm_k / ref_norm - 1.0) <= NORM_TOLERANCE) & (
        np.abs(dip_k - ref_dip) <= DIP_TOLERANCE_DEG
    )
    drift_deg_s = _steady_turn_deg_s(centres[earthlike], raw_heading_k[earthlike])
    heading = heading - drift_deg_s * (t - t[0])
    heading_k = np.array([np.median(heading[a:b]) for a, b in bounds])
    spread_k = np.array([_robust_spread(heading[a:b]) for a, b in bounds])

    reasons: list[str | None] = []
    for k in range(len(bounds)):
        if abs(norm_k[k] / ref_norm - 1.0) > NORM_TOLERANCE:
            reasons.append(f"field norm {norm_k[k]:.0f} µT, reference {ref_norm:.0f} µT")
        elif abs(dip_k[k] - ref_dip) > DIP_TOLERANCE_DEG:
            reasons.append(f"field dip {dip_k[k]:.0f} deg, reference {ref_dip:.0f} deg")
        elif spread_k[k] > SPREAD_TOLERANCE_DEG:
            reasons.append(f"field turning: its heading spreads {spread_k[k]:.0f} deg within the stretch")
        else:
            reasons.append(None)
    candidate = np.array([r is None for r in reasons])
    for k in np.flatnonzero(candidate):  # residual against the candidate neighbours' field heading
        near = candidate & (np.abs(centres - centres[k]) <= NEIGHBOURS_S)
        near[k] = False
        if near.any():
            residual = float(np.median(_wrap_deg(heading_k[k] - heading_k[near])))
            if abs(residual) > RESIDUAL_TOLERANCE_DEG:
                reasons[k] = f"heading residual: the field turned {residual:+.0f} deg against its neighbours"
    clean = np.array([r is None for r in reasons])
    if not EARTH_FIELD_UT[0] <= ref_norm <= EARTH_FIELD_UT[1]:  # no stretch is the Earth's field alone
        reasons = [f"the walk's quietest field, {ref_norm:.0f} µT, is not the Earth's" for _ in reasons]
        clean[:] = False
    q9 = np.asarray(out["quat9D"], dtype=np.float64)
    clean_fraction = float(sum(b - a for (a, b), c in zip(bounds, clean, strict=True) if c) / len(t))
    earth = EARTH_FIELD_UT[0] <= ref_norm <= EARTH_FIELD_UT[1]
    if earth and clean_fraction < MIN_CLEAN_FRACTION and abs(drift_deg_s) * 60.0 > MAX_GYRO_DRIFT_DEG_MIN:
        why = (
            f"the field is clean too rarely ({clean_fraction:.0%}) but the gyroscope's heading turns "
            f"{abs(drift_deg_s) * 60.0:.0f} deg/min against it: VQF 9-D with its own disturbance rejection"
        )
        whole = [Stretch(float(t[0]), float(t[-1]), VQF9D, why)]
        return MagTrust(whole, q9, q9, clean_fraction, ref_norm, ref_dip)
    # A disturbed stretch VQF itself rejected (``magDistDetected`` over most of it) keeps VQF 9-D: it
    # already holds the gyroscope's heading there, sample by sample, with no interpolation to drift.
    rejected = np.array([np.mean(out["magDistDetected"][a:b]) >= REJECTED_FRACTION for a, b in bounds])
    use9 = clean | rejected
    if clean_fraction < MIN_CLEAN_FRACTION:
        use9[:] = False
        q = np.asarray(out["quat6D"], dtype=np.float64)
    else:
        # VQF's heading correction from 6-D's world to magnetic north (``delta``: the yaw of R9 R6^-1) where
        # 9-D is kept, interpolated through the stretches VQF took a disturbed field in.
        kept = np.concatenate([np.arange(a, b) for (a, b), k in zip(bounds, use9, strict=True) if k])
        # VQF's offline heading is smoothed forwards and backwards (``tauMag``): beside a stretch taken
        # from 6-D its correction already leans toward the disturbed field, so the knots keep away.
        far = np.ones(len(t), dtype=bool)
        for (a, b), k in zip(bounds, use9, strict=True):
            if not k:
                far &= (t < t[a] - MARGIN_S) | (t > t[b - 1] + MARGIN_S)
        kept = kept[far[kept]] if far[kept].any() else kept
        delta = np.unwrap(np.asarray(out["delta"], dtype=np.float64))
        turn_deg = np.degrees(np.interp(t, t[kept], delta[kept]))
        q = frames.wxyz_from_rotation(frames.rotation_from_wxyz(_yaw_wxyz(np.radians(turn_deg))) * R6)
        q = frames.make_continuous(q)
    texts = []
    for ok, keep, why in zip(clean, use9, reasons, strict=True):
        if ok:
            texts.append("field clean: heading from the magnetometer (VQF 9-D)")
        elif keep:
            texts.append(f"{why}: VQF 9-D rejected it itself (its gyroscope heading held there)")
        elif clean_fraction < MIN_CLEAN_FRACTION:
            texts.append(f"{why}; the walk's field is clean too rarely: VQF 6-D")
        else:
            texts.append(f"{why}, taken by VQF 9-D: VQF 6-D's relative heading")
    stretches = _merged(t, bounds, [VQF9D if k else VQF6D for k in use9], texts)
    return MagTrust(stretches, q, q9, clean_fraction, ref_norm, ref_dip)


def assess_sequence(seq: ImuSequence) -> MagTrust | None:
    """:func:`assess` on a recording with a magnetometer (None without one, or too short)."""
    if seq.mag_uT is None or not np.isfinite(seq.mag_uT).all():
        return None
    return assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)


def oriented(seq: ImuSequence, trust: MagTrust) -> ImuSequence:
    """``seq`` with the heading ``trust`` built: VQF's estimate (its notes, and its ground truth turned
    into the estimate's world at the start), then that orientation, the truth turned once more by the
    heading between it and VQF 9-D's over the first seconds (nothing where the start is clean)."""
    if trust.source == VQF6D:
        return estimate_orientation(seq, use_magnetometer=False)
    out = estimate_orientation(seq, use_magnetometer=True, **VQF_PARAMS)
    if all(s.source == VQF9D for s in trust.stretches):
        return out  # clean throughout: VQF 9-D itself
    gt = out.gt
    if gt is not None:
        yaw, _ = frames.yaw_offset_rad(seq.t_s, trust.q_world_device_wxyz, trust.q9_wxyz, ALIGN_WINDOW_S)
        gt = frames.rotate_trajectory_about_z(gt, yaw)
    meta = {**out.meta, "orientation_filter": "vqf-9d-per-stretch"}
    return out.with_(q_world_device_wxyz=trust.q_world_device_wxyz, gt=gt, meta=meta)


def _stretch_bounds(n: int, size: int) -> list[tuple[int, int]]:
    """``[a, b)`` ranges of ``size`` samples; a last piece under half a stretch joins the one before."""
    starts = list(range(0, n, size))
    bounds = [(a, min(a + size, n)) for a in starts]
    if len(bounds) > 1 and bounds[-1][1] - bounds[-1][0] < size // 2:
        bounds[-2:] = [(bounds[-2][0], n)]
    return bounds


def _steady_turn_deg_s(centres: np.ndarray, heading_k: np.ndarray) -> float:
    """The steady turn of the field's heading in 6-D's world (deg/s): the median of the slopes between
    stretches up to ``NEIGHBOURS_S`` apart (Theil-Sen on the circle: a disturbance's spin adds no turn)."""
    slopes = [
        _wrap_deg(heading_k[j] - heading_k[i]) / (centres[j] - centres[i])
        for i in range(len(centres))
        for j in range(i + 1, len(centres))
        if centres[j] - centres[i] <= NEIGHBOURS_S
    ]
    return float(np.median(slopes)) if slopes else 0.0


def _wrap_deg(x: np.ndarray | float) -> np.ndarray:
    return (np.asarray(x, dtype=np.float64) + 180.0) % 360.0 - 180.0


def _robust_spread(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _yaw_wxyz(yaw_rad: np.ndarray) -> np.ndarray:
    half = 0.5 * np.asarray(yaw_rad, dtype=np.float64)
    zeros = np.zeros_like(half)
    return np.column_stack([np.cos(half), zeros, zeros, np.sin(half)])


def _merged(
    t: np.ndarray, bounds: list[tuple[int, int]], sources: list[str], texts: list[str]
) -> list[Stretch]:
    """Consecutive stretches with the same source and reason merged; a run of 6-D stretches keeps its
    first reason and counts the stretches that had others."""
    found: list[Stretch] = []
    run_texts: list[str] = []
    for (a, b), source, text in zip(bounds, sources, texts, strict=True):
        if found and found[-1].source == source and (source == VQF6D or found[-1].reason == text):
            found[-1] = Stretch(found[-1].t0_s, float(t[b - 1]), source, found[-1].reason)
            run_texts.append(text)
            continue
        _note_more(found, run_texts)
        found.append(Stretch(float(t[a]), float(t[b - 1]), source, text))
        run_texts = [text]
    _note_more(found, run_texts)
    return found


def _note_more(found: list[Stretch], run_texts: list[str]) -> None:
    if found and found[-1].source == VQF6D and len(run_texts) > 1:
        last = found[-1]
        found[-1] = Stretch(
            last.t0_s, last.t1_s, last.source, f"{last.reason} (and {len(run_texts) - 1} more stretches)"
        )
