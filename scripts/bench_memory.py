"""Peak memory of ``predict_trajectory`` on a long recording (default: 1 hour of 200 Hz IMU).

    .venv/bin/python scripts/bench_memory.py                       # 60 min, FTIN default config
    .venv/bin/python scripts/bench_memory.py --minutes 10 --compare-materialised

What is measured: a fresh Python process builds the recording and the model, then calls
``ftin.infer.predict_trajectory`` once; its peak resident set size (``resource.getrusage(RUSAGE_SELF)
.ru_maxrss``) is read before the call (baseline: interpreter, torch, model, recording) and after it;
the difference is the memory inference needed on top. This launcher imports neither numpy nor torch,
so the ru_maxrss that Linux carries over from a parent into its child (fork + exec keeps the parent's
peak) is a few MiB, far below the child's baseline.

The recording is random IMU, not a walk: memory does not depend on the values. Gyro and specific
force are white noise around rest (acc ≈ +9.81 m/s² on z), the device orientation is given (a slow
random yaw), so no AHRS filter runs, and there is no ground truth (no metrics). The model is FTIN in
its default configuration with random weights (``create_model("ftin")``: 100-sample windows) behind a
checkpoint description of 100 Hz and stride 10 (``ftin train``'s defaults), so inference resamples
the 200 Hz recording to 100 Hz first (anti-alias low-pass + interpolation), exactly as for a user's
200 Hz file.

``--compare-materialised`` runs a second fresh process that does what streaming avoids: all windows
of the recording gathered into one ``(M, 6, L)`` array before the model runs over it in batches. The
difference between the two increases is the memory the streaming saves.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

RECORDING_RATE_HZ = 200.0
MODEL = "ftin"
MODEL_RATE_HZ = 100.0  # ftin's default window is 100 samples = the paper's 1 s at 100 Hz
STRIDE = 10  # ftin train's default stride
_MIB = 1024.0 * 1024.0


# --- the measuring process ---------------------------------------------------------------------------


def _random_recording(minutes: float, seed: int):
    """``minutes`` of 200 Hz IMU noise with a given slowly turning device orientation."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from ftin.data.types import ImuSequence

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


def _ftin_default(seed: int):
    import torch

    from ftin.checkpoint import LoadedModel
    from ftin.data.windows import InputNormalization
    from ftin.models import create_model

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


def _predict_materialised(loaded, seq, batch_size: int) -> int:
    """The non-streaming way: every window gathered first; returns the gathered array's bytes."""
    import numpy as np
    import torch

    from ftin.data.prepare import prepare
    from ftin.data.windows import window_view

    prepared = prepare(seq, loaded.imu_rate_hz, loaded.window, loaded.stride)
    imu, starts = prepared.imu_world, prepared.starts
    x_all = np.ascontiguousarray(window_view(imu, loaded.window)[starts])  # (M, 6, L): all at once
    with torch.inference_mode():
        for first in range(0, len(x_all), batch_size):
            loaded.model(torch.from_numpy(x_all[first : first + batch_size]))
    return x_all.nbytes


def measure(minutes: float, batch_size: int, threads: int, materialised: bool, seed: int) -> dict:
    """Run in a fresh process: baseline peak RSS, one prediction, peak RSS after (MiB)."""
    import gc

    import torch

    from ftin.bench import peak_rss_mib
    from ftin.infer import predict_trajectory

    torch.set_num_threads(threads)
    loaded = _ftin_default(seed)
    seq = _random_recording(minutes, seed)
    recording_mib = sum(a.nbytes for a in (seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.q_world_device_wxyz))
    gc.collect()
    baseline = peak_rss_mib()
    start = time.perf_counter()
    if materialised:
        windows_bytes = _predict_materialised(loaded, seq, batch_size)
        n_windows = windows_bytes // (6 * loaded.window * 4)
    else:
        prediction = predict_trajectory(loaded, seq, batch_size=batch_size)
        n_windows = len(prediction.velocity_m_s)
    seconds = time.perf_counter() - start
    after = peak_rss_mib()
    return {
        "mode": "materialised" if materialised else "streamed",
        "minutes": minutes,
        "samples": len(seq),
        "windows": int(n_windows),
        "window": loaded.window,
        "stride": loaded.stride,
        "batch_size": batch_size,
        "threads": threads,
        "recording_mib": recording_mib / _MIB,
        "all_windows_mib": n_windows * 6 * loaded.window * 4 / _MIB,
        "baseline_peak_rss_mib": baseline,
        "after_peak_rss_mib": after,
        "increase_mib": after - baseline,
        "seconds": seconds,
    }


# --- the launcher ------------------------------------------------------------------------------------


def _run_fresh(args: argparse.Namespace, materialised: bool) -> dict:
    command = [
        sys.executable,
        __file__,
        "--child",
        *("--minutes", str(args.minutes), "--batch-size", str(args.batch_size)),
        *("--threads", str(args.threads), "--seed", str(args.seed)),
    ]
    if materialised:
        command.append("--materialised")
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        sys.exit(f"the measuring process failed (status {proc.returncode}):\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _describe(r: dict) -> str:
    return (
        f"{r['mode']:>12}: peak RSS {r['baseline_peak_rss_mib']:.0f} MiB before -> "
        f"{r['after_peak_rss_mib']:.0f} MiB after predicting = +{r['increase_mib']:.0f} MiB "
        f"({r['seconds']:.0f} s)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="recording length (200 Hz)")
    parser.add_argument("--batch-size", type=int, default=1024, help="windows per model call")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compare-materialised", action="store_true", help="also run the non-streaming way")
    parser.add_argument("--json", action="store_true", help="print the measurements as JSON")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--materialised", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.minutes <= 0 or args.batch_size < 1 or args.threads < 1:
        parser.error("--minutes must be > 0, --batch-size and --threads >= 1")
    if args.child:
        result = measure(args.minutes, args.batch_size, args.threads, args.materialised, args.seed)
        print(json.dumps(result))
        return

    results = [_run_fresh(args, materialised=False)]
    if args.compare_materialised:
        results.append(_run_fresh(args, materialised=True))
    if args.json:
        print(json.dumps(results, indent=2))
        return
    r = results[0]
    print(
        f"{MODEL} (default config, random weights), {r['minutes']:g} min of {RECORDING_RATE_HZ:g} Hz IMU "
        f"resampled to {MODEL_RATE_HZ:g} Hz: {r['windows']:,} windows of {r['window']} samples, stride "
        f"{r['stride']}, batch {r['batch_size']}, {r['threads']} thread(s)"
    )
    print(
        f"recording arrays {r['recording_mib']:.0f} MiB; all windows at once would be "
        f"{r['all_windows_mib']:.0f} MiB (float32)"
    )
    for r in results:
        print(_describe(r))


if __name__ == "__main__":
    main()
