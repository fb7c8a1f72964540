"""Probe: what a raw (uncalibrated) magnetometer costs a walk under ``auto``, before and after the check.

    nice -n 10 .venv/bin/python -m experiments.probe_magnetometer [--out docs/results/probes/magnetometer.md]

A phone's raw field is the Earth's, stretched by soft iron and shifted by hard iron. The walks below
carry a calibrated field; each is scored four ways with the default checkpoint
(``checkpoints/ronin_resnet-walking``), phone only (``auto`` chooses from the recording without the
phone's attitude, the truth turned into the estimate's world over the first seconds, as the campaign's
phone-only rows are scored):

* **calibrated field**: the walk as recorded (``apply_phone_only``);
* **raw, trusted**: its field corrupted by a known hard-iron offset ``HARD_IRON_UT`` and soft-iron
  matrix ``SOFT_IRON``, and ``auto`` run as it was before the magnetometer check: the rule of
  ``ftin.data.orientation_choice`` on the raw field, and VQF 9-D reading it when the rule says so;
* **raw, checked**: the same corrupted walk through ``apply_phone_only`` (the check of
  ``ftin.data.magnetometer``: calibrated from the walk's own turns, or dropped for 6-D);
* **6-D**: VQF without the magnetometer, for reference.

ATE (m, RoNIN convention, start-aligned). The walks: Inria walks without magnetic disturbance (turns
every way: a loop in a small room) and OxIOD walks (a trolley that turns about the vertical and tilts
a little; a hand-held walk that only turns about the vertical, whose raw field cannot be calibrated).
One torch thread; a few minutes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from ftin.checkpoint import load_model
from ftin.data.discovery import list_sequences, read_sequence
from ftin.data.magnetometer import decide
from ftin.data.orientation_choice import choose_orientation
from ftin.data.orientation_option import apply_phone_only, phone_only
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence
from ftin.evaluate import score
from ftin.files import DEFAULT_CHECKPOINT_DIR, DEFAULT_DATA_ROOT
from ftin.infer import predict_trajectory

HARD_IRON_UT = np.array([300.0, -150.0, 200.0])
SOFT_IRON = np.array([[1.12, 0.06, -0.03], [0.06, 0.93, 0.04], [-0.03, 0.04, 1.05]])
WALKS = {
    "inria_attitude": [
        "datasets/android/Thibaud_Nexus5_NoDist_AR",
        "datasets/android/Thibaud_Nexus5_NoDist_Phoning",
        "datasets/ios/Guillaume_iPhone4S_NoDist_AR",
        "datasets/ios/Guillaume_iPhone5_NoDist_AR",
    ],
    "oxiod": ["trolley/data2/syn/imu3", "handheld/data1/syn/imu3"],
}
WAYS = ("calibrated field", "raw, trusted", "raw, checked", "6-D")


def corrupted(seq: ImuSequence) -> ImuSequence:
    """``seq`` with its field as an uncalibrated magnetometer would read it."""
    return seq.with_(mag_uT=seq.mag_uT @ SOFT_IRON.T + HARD_IRON_UT)


def trusted(seq: ImuSequence) -> tuple[ImuSequence, str]:
    """``auto`` on a phone export of ``seq`` as it ran before the magnetometer check: the field as read."""
    source, _ = choose_orientation(phone_only(seq))
    return estimate_orientation(seq, use_magnetometer=source == "vqf"), source


def ate(model, seq: ImuSequence) -> float:
    return float(score(predict_trajectory(model, seq), "start").metrics.ate)


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT_DIR / "ronin_resnet-walking")
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/magnetometer.md"))
    args = parse(parser)
    model = load_model(args.checkpoint)
    rows = []
    for dataset, names in WALKS.items():
        refs = {ref.name: ref for ref in list_sequences(args.data_root / dataset)}
        for name in names:
            if name not in refs:
                print(f"skipped {dataset} {name}: not in {args.data_root}")
                continue
            seq = read_sequence(refs[name], orientation="device")
            raw = corrupted(seq)
            original = apply_phone_only(seq)
            before, before_source = trusted(raw)
            after = apply_phone_only(raw)
            six = estimate_orientation(raw, use_magnetometer=False)
            decision = decide(raw.mag_uT)
            fit = decision.fit
            fit_error = "-" if fit is None else f"{np.linalg.norm(fit.offset_uT - HARD_IRON_UT):.1f}"
            ates = [ate(model, s) for s in (original, before, after, six)]
            sources = [original.meta["orientation_choice"]["source"], before_source]
            sources.append(after.meta["orientation_choice"]["source"])
            rows.append((dataset, name, ates, sources, decision, fit_error))
            print(name, [f"{a:.2f}" for a in ates], sources, decision.action.value, flush=True)
    render(args, rows)


def render(args, rows) -> None:
    lines = [
        "# A raw magnetometer under `auto`: before and after the check (a probe)",
        "",
        "Made by `nice -n 10 .venv/bin/python -m experiments.probe_magnetometer` (its docstring: method).",
        f"Default checkpoint `{args.checkpoint.name}`, phone only. Each walk's calibrated field corrupted by",
        f"a hard-iron offset {tuple(int(v) for v in HARD_IRON_UT)} µT",
        f"({np.linalg.norm(HARD_IRON_UT):.0f} µT) and the soft-iron matrix {SOFT_IRON.tolist()}.",
        "Cells: ATE (m, RoNIN convention, start-aligned) and the source `auto` ran; *check*: what",
        "`ftin.data.magnetometer` did with the raw field (offset error: the fitted hard iron's distance",
        "from the true one, µT).",
        "",
        "| walk | " + " | ".join(WAYS) + " | check | offset error |",
        "|---|" + "--:|" * len(WAYS) + "---|--:|",
    ]
    for dataset, name, ates, sources, decision, fit_error in rows:
        cells = [f"{a:.2f} ({s})" for a, s in zip(ates[:3], sources, strict=True)] + [f"{ates[3]:.2f}"]
        check = decision.action.value + (f", coverage {decision.fit.coverage:.2f}" if decision.fit else "")
        walk = f"{dataset} {name.split('/')[-1] if dataset == 'inria_attitude' else name}"
        lines.append(f"| {walk} | " + " | ".join(cells) + f" | {check} | {fit_error} |")
    if rows:
        means = np.mean([r[2] for r in rows], axis=0)
        lines.append("| **mean** | " + " | ".join(f"**{m:.2f}**" for m in means) + " | | |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
