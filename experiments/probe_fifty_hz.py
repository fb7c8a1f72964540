"""What does a 50 Hz recording cost the default? (issue 54: ILC traces are 50 Hz, the model reads 100.)

Walks with dense truth at their native rate (OxIOD validation and stage three's new walkers at 100 Hz,
RIDI validation at 200 Hz), phone only (``apply_phone_only``: ``auto`` orientation from gyroscope,
accelerometer and magnetometer, no attitude of the phone), each read three ways through the normal path
(``predict_trajectory``, scored as ``experiments.probe_new_oxiod_walks.walk_row`` scores: ATE in the
RoNIN convention, the distance ratio):

- ``native``: as recorded (RIDI resampled down to 100 Hz by ``prepare``, as always);
- ``50 Hz``: the raw recording first decimated to 50 Hz (``ftin.data.preprocess.resample``: zero-phase
  Butterworth low-pass at 0.8 x the new Nyquist frequency, then linear interpolation; the truth and the
  magnetometer interpolated), then oriented and read as a 50 Hz phone would be: VQF runs at 50 Hz and
  ``prepare`` interpolates the IMU linearly up to the model's 100 Hz;
- ``50 Hz, band-limited up`` (only to see whether the up-sampling is the cost): the same 50 Hz
  recording brought to 100 Hz by polyphase interpolation (``scipy.signal.resample_poly``) before it is
  oriented, so that ``prepare`` finds it on the model's grid.

The rule, written before any row was read: the resampling is changed when the 50 Hz row's mean ATE over
the walks of any dataset is worse than native by more than 5 % and the band-limited arm recovers at least
half of that loss; otherwise it stays, and the cost is reported.

    nice -n 10 python -m experiments.probe_fifty_hz --out docs/results/probes/fifty_hz.md
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.signal import resample_poly

from experiments.common import argument_parser, parse, write_report
from experiments.probe_new_oxiod_walks import walk_row
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_sequences
from ftin.data.orientation_option import Orientation, apply_phone_only
from ftin.data.preprocess import resample
from ftin.data.types import ImuSequence
from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.stage_three import NEW_VAL

ARMS = ("native", "50 Hz", "50 Hz, band-limited up")
WORSE_AT_MOST = 0.05


def walks(data_root: Path) -> list[tuple[str, str, Path]]:
    """``(dataset label, relative path, path)`` of every walk read."""
    found = []
    for dataset in (protocol.OXIOD, protocol.RIDI):
        for path in protocol.split_paths(data_root, dataset, "val"):
            found.append((protocol.DATASET_LABELS[dataset], str(path.relative_to(data_root)), path))
    for rel in NEW_VAL:
        found.append(("OxIOD new walkers", rel, data_root / rel))
    return found


def band_limited_up(seq: ImuSequence, factor: int) -> ImuSequence:
    """``seq`` (on a uniform grid) at ``factor`` times its rate by polyphase interpolation (IMU and
    magnetometer; the truth and any orientation linearly, as ``resample`` would)."""
    linear = resample(seq, seq.rate_hz * factor)  # the grid, the truth and any attitude, linearly
    t = linear.t_s

    def up(x: np.ndarray) -> np.ndarray:
        return resample_poly(x, factor, 1, axis=0)[: len(t)]

    gt, q = linear.gt, linear.q_world_device_wxyz
    mag = None if seq.mag_uT is None else up(seq.mag_uT)
    return ImuSequence(seq.name, t, up(seq.gyro_rad_s), up(seq.acc_m_s2), q, gt, dict(seq.meta), mag)


def arms_of(seq: ImuSequence) -> dict[str, ImuSequence]:
    fifty = resample(seq, 50.0, antialias=True)
    return {"native": seq, "50 Hz": fifty, "50 Hz, band-limited up": band_limited_up(fifty, 2)}


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ronin_resnet-walking"))
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    model = load_model(args.checkpoint)
    found = walks(args.data_root)
    read = load_sequences([w[2] for w in found], "50 Hz probe walks", Orientation.DEVICE.value)
    rows: list[dict] = []
    started = time.monotonic()
    for (label, rel, _), seq in zip(found, read, strict=True):
        for arm, variant in arms_of(seq).items():
            row = walk_row(model, rel, apply_phone_only(variant))
            row.update(dataset=label, arm=arm, rate_hz=round(seq.rate_hz))
            rows.append(row)
            print(f"{arm:>24} {rel}: ATE {row['ate']:.3f} ratio {row['ratio']}", flush=True)
    minutes = (time.monotonic() - started) / 60
    write_report(args.out, report(rows, args.checkpoint, minutes))


def report(rows: list[dict], checkpoint: Path, minutes: float) -> list[str]:
    lines = [
        "# What 50 Hz costs the default (phone only)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_fifty_hz --out docs/results/probes/fifty_hz.md` "
        f"({minutes:.0f} min on two shared cores; checkpoint `{checkpoint}`). Its docstring: method and the "
        "rule, written before any row was read. ATE (m, RoNIN convention, no alignment), distance ratio "
        "(predicted over walked path); change against native in brackets.",
        "",
        "| dataset (native rate) | walks | arm | mean ATE | change | ratio mean | ratio min-max |",
        "|---|--:|---|--:|--:|--:|---|",
    ]
    verdicts = []
    for dataset in dict.fromkeys(r["dataset"] for r in rows):
        part = [r for r in rows if r["dataset"] == dataset]
        native = float(np.mean([r["ate"] for r in part if r["arm"] == "native"]))
        changes = {}
        for arm in ARMS:
            mine = [r for r in part if r["arm"] == arm]
            ate = float(np.mean([r["ate"] for r in mine]))
            ratios = [r["ratio"] for r in mine if r["ratio"] is not None]
            changes[arm] = ate / native - 1
            lines.append(
                f"| {dataset} ({mine[0]['rate_hz']} Hz) | {len(mine)} | {arm} | {ate:.3f} "
                f"| {changes[arm]:+.1%} | {np.mean(ratios):.3f} | {min(ratios):.2f}-{max(ratios):.2f} |"
            )
        loss, limited = changes["50 Hz"], changes["50 Hz, band-limited up"]
        change = loss > WORSE_AT_MOST and (loss - limited) >= loss / 2
        verdicts.append(
            f"{dataset}: 50 Hz {loss:+.1%}, band-limited up {limited:+.1%}: "
            f"{'change the up-sampling' if change else 'keep the resampling'}"
        )
    lines += ["", "## Verdict by the rule", "", *(f"- {v}" for v in verdicts)]
    return lines


if __name__ == "__main__":
    main()
