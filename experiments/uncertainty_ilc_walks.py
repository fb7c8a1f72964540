"""The ILC mall walks the held-out uncertainty probe reads (``experiments.probe_uncertainty_heldout``),
each predicted once by the default model, phone only (``predict_trajectory``, as
``experiments.probe_ilc_baseline`` reads them), and kept as a small npz: times, predicted positions,
the spans and per-window velocities (and log-std) ``ftin.uncertainty`` propagates, and the surveyor's
waypoints (sparse truth, map frame, ``ftin.data.readers.ilc``).

Every ``every``-th trace of a floor in file-name order (the baseline probe's rule): a fixed sample
spread over each floor's recording days.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data.discovery import read_sequence
from ftin.infer import predict_trajectory


def floor_walks(data_root: Path, floor: str, every: int) -> list[Path]:
    return sorted((data_root / "ilc" / "site1" / floor).glob("*.txt.xz"))[::every]


def ilc_record(model: LoadedModel, path: Path, floor: str) -> dict[str, np.ndarray] | None:
    """One ILC walk predicted and reduced to what the probe reads; None with fewer than two marks."""
    seq = read_sequence(path)
    if seq.waypoints is None or len(seq.waypoints) < 2:
        return None
    prediction = predict_trajectory(model, seq, keep_prepared=False)
    log_std = (prediction.features or {}).get("log_std")
    return {
        "dataset": np.array(f"ilc {floor}"),
        "name": np.array(path.name.removesuffix(".txt.xz")),
        "carry": np.array(str(seq.meta.get("carry", "handheld"))),
        "orientation_filter": np.array(str(prediction.orientation_filter)),
        "t_s": prediction.trajectory.t_s,
        "p_pred": prediction.trajectory.p_world_m[:, :2],
        "span_t_s": prediction.span_t_s,
        "v_pred": prediction.velocity_m_s[:, :2],
        "window_s": np.array(prediction.window_s),
        "wp_t_s": seq.waypoints.t_s,
        "wp_xy_m": seq.waypoints.xy_map_m,
        **({} if log_std is None else {"log_std": np.asarray(log_std, dtype=np.float64)[:, :2]}),
    }


def cached_ilc_walks(
    model: LoadedModel, data_root: Path, cache: Path, floors: tuple[str, ...], every: int
) -> list[dict[str, np.ndarray]]:
    """Every ``every``-th walk of each floor as ``ilc_record``, read from ``cache`` where already there."""
    records = []
    for floor in floors:
        for path in floor_walks(data_root, floor, every):
            file = cache / floor / f"{path.name.removesuffix('.txt.xz')}.npz"
            skip = file.with_suffix(".none")
            if not file.exists() and not skip.exists():
                record = ilc_record(model, path, floor)
                file.parent.mkdir(parents=True, exist_ok=True)
                if record is None:
                    skip.touch()
                else:
                    np.savez(file, **record)
                print(f"ilc {floor} {path.name}: predicted", flush=True)
            if file.exists():
                with np.load(file) as data:
                    records.append({k: data[k] for k in data.files})
    return records
