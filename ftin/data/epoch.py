"""When a recording started on the phone's own clock: ``meta["start_epoch_s"]``, the instant of the
sequence's t = 0 in seconds since the Unix epoch (UTC), where the export says it.

Every sequence counts its time from its first common sample (``t_s[0] == 0``); exports that people
load elsewhere (GPX, or a CSV beside other logs of the same walk) want the phone's clock instead.

Where it comes from:
- Sensor Logger: its ``time`` columns are nanoseconds since the epoch; t = 0 is the reader's first
  common instant on that clock (``ftin.data.readers.sensorlogger``).
- phyphox: ``meta/time.csv`` pairs the experiment's clock with the system clock at each ``START``
  (columns ``event``, ``experiment time``, ``system time`` (s since the epoch), ``system time
  text``, as phyphox documents its export; the shared phyphox export has no ``meta/`` folder, so this
  is checked on a file written in that layout). A run paused and resumed has one ``START`` a stretch:
  the last one at or before t = 0 maps it.
- EuRoC: its timestamps are nanoseconds since the epoch too (``meta["t0_ns"]``).
Anything else (a generic CSV, a dataset with a device clock, a live stream) has none: ``None``.

A value outside ``PLAUSIBLE_S`` (years 2000-2100) is a device clock, not the epoch, and is dropped.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

START_KEY = "start_epoch_s"
PLAUSIBLE_S = (946_684_800.0, 4_102_444_800.0)  # 2000-01-01 .. 2100-01-01 UTC


def plausible(epoch_s: float | None) -> float | None:
    """``epoch_s`` if it reads as a date in 2000-2100, else None."""
    if epoch_s is None or not np.isfinite(epoch_s):
        return None
    return float(epoch_s) if PLAUSIBLE_S[0] <= epoch_s <= PLAUSIBLE_S[1] else None


def start_meta(epoch_s: float | None) -> dict[str, float]:
    """The ``meta`` entry a reader adds (empty when the start is unknown or implausible)."""
    value = plausible(epoch_s)
    return {} if value is None else {START_KEY: value}


def start_epoch_s(meta: Mapping[str, Any]) -> float | None:
    """The instant of t = 0 in seconds since the epoch, from a sequence's ``meta``; None if unknown."""
    value = meta.get(START_KEY)
    if value is None and meta.get("dataset") == "euroc" and meta.get("t0_ns") is not None:
        value = int(meta["t0_ns"]) * 1e-9
    return plausible(None if value is None else float(value))


def phyphox_start_epoch_s(extra: Mapping[str, bytes], zero_s: float) -> float | None:
    """phyphox's ``meta/time.csv`` (``extra``, by base name): the epoch of experiment time ``zero_s``."""
    data = next((v for k, v in extra.items() if k.lower() == "time.csv"), None)
    if not data:
        return None
    try:
        table = pd.read_csv(io.BytesIO(data), skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError):
        return None
    columns = {str(c).strip().strip('"').lower(): c for c in table.columns}
    if not {"event", "experiment time", "system time"} <= set(columns):
        return None
    events = table[columns["event"]].astype(str).str.strip().str.upper()
    experiment = pd.to_numeric(table[columns["experiment time"]], errors="coerce").to_numpy(np.float64)
    system = pd.to_numeric(table[columns["system time"]], errors="coerce").to_numpy(np.float64)
    starts = (events == "START").to_numpy() & np.isfinite(experiment) & np.isfinite(system)
    if not starts.any():
        return None
    before = starts & (experiment <= zero_s + 1e-9)
    row = int(np.flatnonzero(before)[-1] if before.any() else np.flatnonzero(starts)[0])
    return plausible(system[row] + (zero_s - experiment[row]))
