"""Gaps in a recording's clock: bridged, held or refused, the same way for every entry point.

Real phones drop and batch samples (Android's sensor HAL, iOS under load): a 200 Hz RIDI walk loses
six samples at once, a Nexus 5 walk of the Inria benchmark stops every sensor for 3.8 s, a RIDI walk
for 4.4 s. ``mend_clock(seq)`` classifies every interval longer than ``GAP_FACTOR`` times the
median interval:

* **bridged** (up to ``BRIDGE_MAX_S``): the samples are interpolated when the sequence is put on the
  model's grid (``ftin.data.preprocess.resample``: vectors linearly, orientation by slerp) and the
  recording carries one note (count, total, longest, where). Why one second: the model reads 1 s
  windows, so a bridged gap spoils at most the windows that overlap it, and at walking speed
  (~1.4 m/s) one second is under one stride: the distance the interpolation can hide is about a
  step.
* **held** (longer, up to ``HOLD_MAX_S``): no data means no motion evidence, so interpolating would
  invent a walker standing still for seconds. The hole is kept in ``meta["holes_s"]`` and inference
  predicts the parts on either side separately: windows that overlap a hole are not run, and the
  trajectory holds its position across it (``ftin.infer``), with a warning naming the time span.
* **refused** (longer than ``HOLD_MAX_S``): that is two recordings; the error names both rows and
  says where to split the file.

Duplicate rows (same timestamp, same values: a logger writing a batch twice) are dropped with a
note; a timestamp repeated with other values, or time going backwards, stays an error
(``ftin.data.validate.check_increasing``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence

GAP_FACTOR = 5.0  # an interval above 5x the median is a gap, not clock jitter
BRIDGE_MAX_S = 1.0  # interpolated (module docstring: one model window, under one stride)
HOLD_MAX_S = 60.0  # predicted in parts around the hole; longer is another recording

RowLabel = Callable[[int], str]


@dataclass(frozen=True)
class Gap:
    """The interval between samples ``index`` and ``index + 1``."""

    index: int
    start_s: float
    end_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def find_gaps(t_s: np.ndarray, factor: float = GAP_FACTOR, floor_s: float = 0.0) -> list[Gap]:
    """Every interval longer than ``factor`` times the median interval (and than ``floor_s``), in
    time order."""
    if len(t_s) < 3:
        return []
    dt = np.diff(t_s)
    threshold = max(factor * float(np.median(dt)), floor_s)
    return [Gap(int(i), float(t_s[i]), float(t_s[i + 1])) for i in np.flatnonzero(dt > threshold)]


def sort_gaps(gaps: list[Gap]) -> tuple[list[Gap], list[Gap], list[Gap]]:
    """``(bridged, held, too_long)`` by the rule of the module docstring."""
    bridged = [g for g in gaps if g.duration_s <= BRIDGE_MAX_S]
    held = [g for g in gaps if BRIDGE_MAX_S < g.duration_s <= HOLD_MAX_S]
    return bridged, held, [g for g in gaps if g.duration_s > HOLD_MAX_S]


def drop_repeated_rows(seq: ImuSequence) -> tuple[ImuSequence, np.ndarray | None]:
    """``seq`` without rows that repeat the previous row's timestamp and values exactly, and the
    original index of every row kept (``None`` when nothing was dropped), for row labels."""
    if len(seq) < 2:
        return seq, None
    columns = [seq.gyro_rad_s, seq.acc_m_s2]
    if seq.q_world_device_wxyz is not None:
        columns.append(seq.q_world_device_wxyz)
    if seq.gt is not None:
        columns.append(seq.gt.p_world_m)
    values = np.column_stack([seq.t_s, *columns])
    repeated = np.concatenate([[False], (values[1:] == values[:-1]).all(axis=1)])
    if not repeated.any():
        return seq, None
    keep = np.flatnonzero(~repeated)
    return _take(seq, keep), keep


def _take(seq: ImuSequence, rows: np.ndarray) -> ImuSequence:
    q = None if seq.q_world_device_wxyz is None else seq.q_world_device_wxyz[rows]
    mag = None if seq.mag_uT is None else seq.mag_uT[rows]
    gt = None
    if seq.gt is not None:
        gt_q = None if seq.gt.q_world_body_wxyz is None else seq.gt.q_world_body_wxyz[rows]
        tracked = None if seq.gt.tracked is None else seq.gt.tracked[rows]
        gt = type(seq.gt)(seq.gt.t_s[rows], seq.gt.p_world_m[rows], gt_q, tracked)
    return ImuSequence(
        seq.name,
        seq.t_s[rows],
        seq.gyro_rad_s[rows],
        seq.acc_m_s2[rows],
        q,
        gt,
        dict(seq.meta),
        mag,
        seq.waypoints,
    )


def describe_bridged(gaps: list[Gap], row_label: RowLabel) -> str:
    """One note for every bridged gap of a recording."""
    longest = max(gaps, key=lambda g: g.duration_s)
    total = sum(g.duration_s for g in gaps)
    rows = f"{row_label(longest.index)} and {row_label(longest.index + 1)}"
    where = f"between {rows} (t={longest.start_s:.3f} s)"
    return (
        f"bridged {len(gaps)} gap(s) in the clock by interpolation: {total:.3g} s in all, the longest "
        f"{longest.duration_s * 1000:.0f} ms {where}"
    )


def describe_hole(gap: Gap, row_label: RowLabel) -> str:
    return (
        f"no data for {gap.duration_s:.1f} s between {row_label(gap.index)} (t={gap.start_s:.2f} s) and "
        f"{row_label(gap.index + 1)} (t={gap.end_s:.2f} s): the walk there is unknown; the parts on "
        "either side are predicted separately and the trajectory holds its position across the hole"
    )


def mend_clock(
    seq: ImuSequence, *, source: str, row_label: RowLabel, factor: float = GAP_FACTOR, repeated: int = 0
) -> ImuSequence:
    """``seq`` with its gaps bridged, held or refused (module docstring); ``repeated`` rows dropped
    before (``drop_repeated_rows``) get their note here.

    Notes go to ``meta["notes"]``, held holes to ``meta["holes_s"]`` (``[[start, end], ...]``) with a
    warning each in ``meta["warnings"]``. The clock must already increase.
    """
    notes: list[str] = []
    warnings: list[str] = []
    if repeated:
        notes.append(f"dropped {repeated} repeated row(s) (same timestamp and values as the row before)")
    bridged, held, too_long = sort_gaps(find_gaps(seq.t_s, factor))
    if too_long:
        g = too_long[0]
        raise DataFormatError(
            f"{source}: no data for {g.duration_s:.4g} s between {row_label(g.index)} (t={g.start_s:.10g} s) "
            f"and {row_label(g.index + 1)} (t={g.end_s:.10g} s), more than {HOLD_MAX_S:g} s: these are two "
            f"recordings; split the file there and predict each ({len(too_long)} such gap(s))"
        )
    if bridged:
        notes.append(describe_bridged(bridged, row_label))
    warnings.extend(describe_hole(g, row_label) for g in held)
    if not (notes or warnings):
        return seq
    meta = dict(seq.meta)
    meta["notes"] = [*meta.get("notes", []), *notes]
    meta["warnings"] = [*meta.get("warnings", []), *warnings]
    if held:
        meta["holes_s"] = [*meta.get("holes_s", []), *([g.start_s, g.end_s] for g in held)]
    return seq.with_(meta=meta)


def holes_of(seq: ImuSequence) -> np.ndarray:
    """``(H, 2)`` start and end times of the held holes (``mend_clock``), empty when none."""
    return np.asarray(seq.meta.get("holes_s", []), dtype=np.float64).reshape(-1, 2)


def starts_outside_holes(seq: ImuSequence, starts: np.ndarray, window: int) -> np.ndarray:
    """The window starts whose ``window`` samples see no held hole (training must not learn from
    invented data)."""
    holes = holes_of(seq)
    if not len(holes) or not len(starts):
        return starts
    t = seq.t_s
    a, b = t[starts], t[np.minimum(starts + window, len(t) - 1)]
    blind = ((a[:, None] < holes[None, :, 1]) & (b[:, None] > holes[None, :, 0])).any(axis=1)
    return starts[~blind]
