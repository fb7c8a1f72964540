"""Peak memory of ``predict_trajectory`` on a long recording (default: 1 hour of 200 Hz IMU), each
measurement in a fresh process (``ftin bench memory``).

What is measured: a fresh Python process (``python -m ftin.bench.memory``) builds the recording and the
model, then calls ``ftin.infer.predict_trajectory`` once; its peak resident set size is read before the
call (baseline: interpreter, torch, model, recording) and after it; the difference is the memory
inference needed on top. The peak is the process image's own (``VmHWM``; ``ru_maxrss`` where there is
no ``/proc``): Linux carries a parent's peak into ``ru_maxrss`` across fork + exec, and the launcher
(``ftin``, torch loaded) is as large as the measuring process's baseline.

The recording is random IMU, not a walk: memory does not depend on the values. Gyro and specific
force are white noise around rest (acc ≈ +9.81 m/s² on z), the device orientation is given (a slow
random yaw), so no AHRS filter runs, and there is no ground truth (no metrics). The model is FTIN in
its default configuration with random weights (``create_model("ftin")``: 100-sample windows) behind a
checkpoint description of 100 Hz and stride 10 (``ftin train``'s defaults), so inference resamples
the 200 Hz recording to 100 Hz first (anti-alias low-pass + interpolation), exactly as for a user's
200 Hz file.

``compare_materialised`` runs a second fresh process that does what streaming avoids: all windows
of the recording gathered into one ``(M, 6, L)`` array before the model runs over it in batches. The
difference between the two increases is the memory the streaming saves.
"""

from __future__ import annotations

import argparse
import gc
import json
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.spatial.transform import Rotation

from ftin.checkpoint import LoadedModel
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence
from ftin.data.windows import InputNormalization, window_view
from ftin.infer import predict_trajectory
from ftin.models import create_model

RECORDING_RATE_HZ = 200.0
MODEL = "ftin"
MODEL_RATE_HZ = 100.0  # ftin's default window is 100 samples = the paper's 1 s at 100 Hz
STRIDE = 10  # ftin train's default stride
_MIB = 1024.0 * 1024.0


@dataclass(frozen=True)
class MemoryConfig:
    """One measurement: the recording's length, the model's batch and threads, the random seed."""

    minutes: float = 60.0
    batch_size: int = 1024
    threads: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        if self.minutes <= 0 or self.batch_size < 1 or self.threads < 1:
            raise ValueError("--minutes must be > 0, --batch-size and --threads >= 1")


# --- the measuring process ---------------------------------------------------------------------------


def image_peak_mib() -> float:
    """This process image's peak resident set size (``VmHWM``), in MiB; ``ru_maxrss`` without /proc."""
    status = Path("/proc/self/status")
    if status.exists():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / _MIB if sys.platform == "darwin" else peak / 1024.0  # bytes on macOS, KiB else


def random_recording(minutes: float, seed: int) -> ImuSequence:
    """``minutes`` of 200 Hz IMU noise with a given slowly turning device orientation."""
    rng = np.random.default_rng(seed)
    n = int(round(minutes * 60.0 * RECORDING_RATE_HZ)) + 1
    t_s = np.arange(n) / RECORDING_RATE_HZ
    gyro_rad_s = rng.normal(0.0, 0.5, size=(n, 3))
    acc_m_s2 = rng.normal(0.0, 1.0, size=(n, 3))
    acc_m_s2[:, 2] += 9.81
    yaw_rad = np.cumsum(rng.normal(0.0, 0.01, size=n))
    q_world_device_wxyz = Rotation.from_euler("z", yaw_rad[:, None]).as_quat(scalar_first=True)
    meta = {"dataset": "random", "orientation_source": "device", "rate_hz": RECORDING_RATE_HZ}
    return ImuSequence("random_imu", t_s, gyro_rad_s, acc_m_s2, q_world_device_wxyz, None, meta)


def ftin_default(seed: int) -> LoadedModel:
    """FTIN in its default configuration with random weights, as a checkpoint of 100 Hz, stride 10."""
    torch.manual_seed(seed)
    model = create_model(MODEL).eval()
    window = int(model.config["window"])
    return LoadedModel(
        model,
        f"{MODEL}-random",
        MODEL,
        MODEL_RATE_HZ,
        window,
        STRIDE,
        model.out_dim,
        InputNormalization(),
        {},
    )


def _predict_materialised(loaded: LoadedModel, seq: ImuSequence, batch_size: int) -> int:
    """The non-streaming way: every window gathered first; returns the gathered array's bytes."""
    prepared = prepare(seq, loaded.imu_rate_hz, loaded.window, loaded.stride)
    imu, starts = prepared.imu_world, prepared.starts
    x_all = np.ascontiguousarray(window_view(imu, loaded.window)[starts])  # (M, 6, L): all at once
    with torch.inference_mode():
        for first in range(0, len(x_all), batch_size):
            loaded.model(torch.from_numpy(x_all[first : first + batch_size]))
    return x_all.nbytes


def measure(config: MemoryConfig, materialised: bool) -> dict:
    """Run in a fresh process: baseline peak RSS, one prediction, peak RSS after (MiB)."""
    torch.set_num_threads(config.threads)
    loaded = ftin_default(config.seed)
    seq = random_recording(config.minutes, config.seed)
    recording_mib = sum(a.nbytes for a in (seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.q_world_device_wxyz))
    gc.collect()
    baseline = image_peak_mib()
    start = time.perf_counter()
    if materialised:
        windows_bytes = _predict_materialised(loaded, seq, config.batch_size)
        n_windows = windows_bytes // (6 * loaded.window * 4)
    else:
        prediction = predict_trajectory(loaded, seq, batch_size=config.batch_size)
        n_windows = len(prediction.velocity_m_s)
    seconds = time.perf_counter() - start
    after = image_peak_mib()
    return {
        "mode": "materialised" if materialised else "streamed",
        "minutes": config.minutes,
        "samples": len(seq),
        "windows": int(n_windows),
        "window": loaded.window,
        "stride": loaded.stride,
        "batch_size": config.batch_size,
        "threads": config.threads,
        "recording_mib": recording_mib / _MIB,
        "all_windows_mib": n_windows * 6 * loaded.window * 4 / _MIB,
        "baseline_peak_rss_mib": baseline,
        "after_peak_rss_mib": after,
        "increase_mib": after - baseline,
        "seconds": seconds,
    }


# --- the launcher ------------------------------------------------------------------------------------


def measure_fresh(config: MemoryConfig, materialised: bool) -> dict:
    """``measure`` in a fresh ``python -m ftin.bench.memory`` process; its JSON line back."""
    command = [sys.executable, "-m", __name__, json.dumps(config.__dict__)]
    if materialised:
        command.append("--materialised")
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"the measuring process failed (status {proc.returncode}):\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def measure_memory(config: MemoryConfig, compare_materialised: bool = False) -> list[dict]:
    """The streamed prediction's measurement, and the materialised one's when asked."""
    results = [measure_fresh(config, materialised=False)]
    if compare_materialised:
        results.append(measure_fresh(config, materialised=True))
    return results


def describe(results: list[dict]) -> list[str]:
    """The measurements as lines of text: the set-up, then one line per mode."""
    r = results[0]
    lines = [
        f"{MODEL} (default config, random weights), {r['minutes']:g} min of {RECORDING_RATE_HZ:g} Hz IMU "
        f"resampled to {MODEL_RATE_HZ:g} Hz: {r['windows']:,} windows of {r['window']} samples, stride "
        f"{r['stride']}, batch {r['batch_size']}, {r['threads']} thread(s)",
        f"recording arrays {r['recording_mib']:.0f} MiB; all windows at once would be "
        f"{r['all_windows_mib']:.0f} MiB (float32)",
    ]
    for r in results:
        lines.append(
            f"{r['mode']:>12}: peak RSS {r['baseline_peak_rss_mib']:.0f} MiB before -> "
            f"{r['after_peak_rss_mib']:.0f} MiB after predicting = +{r['increase_mib']:.0f} MiB "
            f"({r['seconds']:.0f} s)"
        )
    return lines


if __name__ == "__main__":  # the measuring process started by ``measure_fresh``
    parser = argparse.ArgumentParser(description="one measurement of ftin.bench.memory, as JSON")
    parser.add_argument("config", help="MemoryConfig fields as JSON")
    parser.add_argument("--materialised", action="store_true")
    args = parser.parse_args()
    print(json.dumps(measure(MemoryConfig(**json.loads(args.config)), args.materialised)))
