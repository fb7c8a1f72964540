"""Orientation sources against motion capture on validation recordings (docs/orientation.md).

Recordings: the OxIOD and RIDI validation parts (``ftin.protocol.SPLITS[...]["val"]``) and every
Nexus 5 and iPhone 5 walk of the Inria attitude benchmark (its iPhone 4S walks are the test part and
are never read here). For each, the ground-truth device orientation (Vicon, Tango, Qualisys, as the
readers give it in ``gt.q_world_body_wxyz``) is compared with

- ``device``: the phone's own attitude (what a phone export carries),
- ``vqf``: VQF 9-D from the recording's gyroscope, accelerometer and magnetometer,
- ``vqf6d``: VQF without the magnetometer,
- ``auto``: the source :func:`ftin.data.orientation_choice.choose_orientation` picks.

Errors: tilt = angle between the estimated and the true gravity direction in the device frame (no
heading involved); heading = drift of the yaw of ``R_true(t) R_est(t)^-1`` from its mean over the
first 5 s (heading offsets between worlds are arbitrary), wrapped to +-180 deg, as RMS over the
recording and at its end.
Only samples the mocap tracked count (``gt.tracked``). With ``--checkpoint``, each source's ATE too,
averaged over the world turned to ``HEADINGS`` headings (``ate_m``). ``--rows`` re-renders an earlier
``--json`` (the rule re-applied to its stored evidence; ``--refresh-evidence`` measures it again)
without the slow predictions.

``--phone-only`` strips the phone's attitude first, as a phone export without orientation gives the
recording (t, gyroscope, accelerometer, magnetometer): only ``vqf``, ``vqf6d`` and ``auto`` exist
then; ``--compare`` takes the full study's ``--json`` for the ``device`` ATE the criterion names.

    .venv/bin/python -m experiments.orientation_quality ../shared/data \
        --checkpoint checkpoints/ftin-pedestrian --json runs/orientation_study.json --out docs/orientation.md
    .venv/bin/python -m experiments.orientation_quality ../shared/data --phone-only \
        --checkpoint checkpoints/ftin-pedestrian --json runs/orientation_phone.json \
        --compare runs/orientation_study.json --out docs/orientation.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse
from ftin import protocol
from ftin.checkpoint import LoadedModel, load_model
from ftin.data import frames
from ftin.data.discovery import read_sequence
from ftin.data.orientation_choice import (
    OrientationEvidence,
    choose_orientation,
    heading_drift_deg,
    orientation_evidence,
)
from ftin.data.orientation_option import phone_only
from ftin.data.preprocess import estimate_orientation
from ftin.data.readers import inria_attitude
from ftin.data.types import ImuSequence
from ftin.evaluate import score
from ftin.infer import predict_trajectory

ALIGN_S = 5.0
HEADINGS = 4
SOURCES = ("device", "vqf", "vqf6d", "auto")  # auto: whichever of the others the rule picks
PHONE_SOURCES = ("vqf", "vqf6d", "auto")  # --phone-only: no phone attitude to choose
VALIDATION_PHONES = ("nexus5", "iphone5")  # Inria: the iPhone 4S walks are the test part


def validation_recordings(data_root: Path) -> list[tuple[str, Path]]:
    """``(dataset, path)`` of every validation recording present under ``data_root``."""
    found: list[tuple[str, Path]] = []
    for dataset in (protocol.OXIOD, protocol.RIDI):
        found += [(dataset, p) for p in protocol.split_paths(data_root, dataset, "val") if p.exists()]
    inria = data_root / "inria_attitude"
    if inria.is_dir():
        for path in inria_attitude.discover(inria):
            if path.name.split("_")[1] != protocol.INRIA_TEST_PHONE:  # the test part: never read here
                found.append(("inria", path))
    return found


def tilt_error_deg(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    up = np.array([0.0, 0.0, 1.0])
    u_est = frames.rotation_from_wxyz(q_est).inv().apply(up)
    u_true = frames.rotation_from_wxyz(q_true).inv().apply(up)
    return np.degrees(np.arccos(np.clip(np.sum(u_est * u_true, axis=1), -1.0, 1.0)))


def kind_of(dataset: str, seq: ImuSequence) -> str:
    """The recording kind a row is grouped by: carry mode, and the Dist / NoDist label on Inria."""
    carry = seq.meta.get("carry", "unknown")
    if dataset == "inria":
        return f"{carry}, {'Dist' if seq.meta['magnetic_disturbance'] else 'NoDist'}"
    return carry


def with_sources(seq: ImuSequence, strip: bool = False) -> dict[str, ImuSequence]:
    """The recording with each source's orientation (ground truth turned into that world at the start;
    with ``strip`` the phone's attitude is removed first and the ground truth keeps its own world)."""
    if strip:
        bare = phone_only(seq)
        return {
            "vqf": estimate_orientation(bare),
            "vqf6d": estimate_orientation(bare, use_magnetometer=False),
        }
    return {
        "device": seq,
        "vqf": estimate_orientation(seq),
        "vqf6d": estimate_orientation(seq, use_magnetometer=False),
    }


def ate_m(model: LoadedModel, seq: ImuSequence, headings: int = HEADINGS) -> float:
    """ATE (RoNIN convention, start-aligned) of ``model`` on ``seq``, averaged over the world turned to
    ``headings`` headings: the network is not exactly heading-invariant, and one arbitrary heading
    moves its ATE by up to 4x (RIDI ma_handheld3: 0.75-2.06 m over 8 headings), more than any
    difference between orientation sources."""
    ates = []
    for k in range(headings):
        yaw = 2.0 * np.pi * k / headings
        turned = frames.wxyz_from_rotation(
            frames.yaw_rotation(yaw) * frames.rotation_from_wxyz(seq.q_world_device_wxyz)
        )
        moved = seq.with_(q_world_device_wxyz=turned, gt=frames.rotate_trajectory_about_z(seq.gt, yaw))
        ates.append(score(predict_trajectory(model, moved), "start").metrics.ate)
    return float(np.mean(ates))


def study_row(dataset: str, path: Path, model: LoadedModel | None, strip: bool = False) -> dict:
    seq = read_sequence(path, orientation="device")
    truth = seq.gt.q_world_body_wxyz
    tracked = seq.gt.tracked_mask
    t = seq.t_s[tracked]
    sources = with_sources(seq, strip)
    estimates = {label: s.q_world_device_wxyz for label, s in sources.items()}
    evidence = orientation_evidence(phone_only(seq) if strip else seq)
    row = {
        "dataset": dataset,
        "name": seq.name,
        "kind": kind_of(dataset, seq),
        "platform": seq.meta.get("platform", "ios" if dataset == "oxiod" else "android"),
        "minutes": round(seq.duration_s / 60.0, 2),
        "evidence": evidence.to_json(),
    }
    if dataset == "inria":
        row["magnetic_disturbance"] = bool(seq.meta["magnetic_disturbance"])
    for label, q in estimates.items():
        tilt = tilt_error_deg(q[tracked], truth[tracked])
        heading = (heading_drift_deg(t, truth[tracked], q[tracked], ALIGN_S) + 180.0) % 360.0 - 180.0
        row[label] = {
            "tilt_rms": float(np.sqrt(np.mean(tilt**2))),
            "heading_rms": float(np.sqrt(np.mean(heading**2))),
            "heading_end": float(abs(heading[-1])),
        }
        if model is not None:
            row[label]["ate"] = ate_m(model, sources[label])
    return row


def apply_rule(row: dict) -> None:
    """(Re)decide ``auto`` from the row's stored evidence, so a changed rule needs no re-run."""
    fields = {f: row["evidence"].get(f) for f in OrientationEvidence.__dataclass_fields__}
    source, reason = choose_orientation(None, OrientationEvidence(**fields))
    row["auto_source"], row["auto_reason"], row["auto"] = source, reason, row[source]


def _groups(rows: list[dict]) -> list[tuple[str, str, list[dict]]]:
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["dataset"], r["kind"]), []).append(r)
    return [(dataset, kind, members) for (dataset, kind), members in sorted(groups.items())]


def _mean(members: list[dict], source: str, key: str) -> float:
    return float(np.mean([r[source][key] for r in members]))


def _sources(rows: list[dict]) -> tuple[str, ...]:
    return SOURCES if all("device" in r for r in rows) else PHONE_SOURCES


def error_table(rows: list[dict]) -> list[str]:
    """Tilt RMS, heading RMS and heading at the end (deg) per source, mean over each kind's recordings."""
    sources = _sources(rows)
    lines = [
        "| dataset | kind | n | " + " | ".join(sources) + " | auto chose |",
        "|:--|:--|--:|" + "--:|" * len(sources) + ":--|",
    ]
    for dataset, kind, members in _groups(rows):
        cells = [
            " / ".join(f"{_mean(members, s, k):.1f}" for k in ("tilt_rms", "heading_rms", "heading_end"))
            for s in sources
        ]
        chosen: dict[str, int] = {}
        for r in members:
            chosen[r["auto_source"]] = chosen.get(r["auto_source"], 0) + 1
        picks = ", ".join(f"{k} {v}" for k, v in sorted(chosen.items()))
        lines.append(f"| {dataset} | {kind} | {len(members)} | " + " | ".join(cells) + f" | {picks} |")
    return lines


def ate_table(rows: list[dict]) -> list[str]:
    """Mean ATE (m) per source and kind, and auto against the better of device and vqf."""
    lines = [
        "| dataset | kind | n | " + " | ".join(SOURCES) + " | auto / min(device, vqf) |",
        "|:--|:--|--:|" + "--:|" * (len(SOURCES) + 1),
    ]
    for dataset, kind, members in _groups(rows):
        ates = {s: _mean(members, s, "ate") for s in SOURCES}
        ratio = ates["auto"] / min(ates["device"], ates["vqf"])
        cells = " | ".join(f"{ates[s]:.2f}" for s in SOURCES)
        lines.append(f"| {dataset} | {kind} | {len(members)} | {cells} | {ratio:.2f} |")
    return lines


def phone_ate_table(rows: list[dict], full: dict[str, dict]) -> list[str]:
    """Phone-only ATE (m) per kind: ``vqf``, ``vqf6d``, ``auto``, beside the ``device`` and ``vqf`` ATE of
    the same recordings with the phone's attitude (``full``: the full study's rows by name), and
    ``auto`` against the better of those two (the criterion)."""
    lines = [
        "| dataset | kind | n | vqf | vqf6d | auto | auto chose | device (with attitude) "
        "| auto / min(device, vqf) |",
        "|:--|:--|--:|--:|--:|--:|:--|--:|--:|",
    ]
    for dataset, kind, members in _groups(rows):
        ates = {s: _mean(members, s, "ate") for s in PHONE_SOURCES}
        device = float(np.mean([full[r["name"]]["device"]["ate"] for r in members]))
        chosen: dict[str, int] = {}
        for r in members:
            chosen[r["auto_source"]] = chosen.get(r["auto_source"], 0) + 1
        picks = ", ".join(f"{k} {v}" for k, v in sorted(chosen.items()))
        ratio = ates["auto"] / min(device, ates["vqf"])
        cells = " | ".join(f"{ates[s]:.2f}" for s in PHONE_SOURCES)
        lines.append(
            f"| {dataset} | {kind} | {len(members)} | {cells} | {picks} | {device:.2f} | {ratio:.2f} |"
        )
    return lines


def replace_between(path: Path, marker: str, table: str) -> None:
    """Replace what lies between ``<!-- marker:start -->`` and ``<!-- marker:end -->``; keep the prose."""
    text = path.read_text()
    head, rest = text.split(f"<!-- {marker}:start -->", 1)
    tail = rest.split(f"<!-- {marker}:end -->", 1)[1]
    path.write_text(f"{head}<!-- {marker}:start -->\n{table}\n<!-- {marker}:end -->{tail}")


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("data_root", type=Path)
    parser.add_argument("--out", type=Path, default=None, help="markdown file with table markers")
    parser.add_argument("--json", type=Path, default=None, help="every row, with its evidence")
    parser.add_argument("--checkpoint", type=Path, default=None, help="also ATE of this model per source")
    parser.add_argument("--rows", type=Path, default=None, help="re-render the rows of an earlier --json")
    parser.add_argument(
        "--refresh-evidence", action="store_true", help="with --rows: measure the evidence again"
    )
    parser.add_argument(
        "--phone-only", action="store_true", help="strip the phone's attitude first (vqf, vqf6d, auto only)"
    )
    parser.add_argument(
        "--compare", type=Path, default=None, help="with --phone-only: the full study's --json (device ATE)"
    )
    args = parse(parser)
    if args.rows is not None:
        rows = json.loads(args.rows.read_text())
        if args.refresh_evidence:  # a new signal: measure it again, keep the (slow) ATE
            paths = {
                read_sequence(p, orientation="device").name: p
                for _, p in validation_recordings(args.data_root)
            }
            for row in rows:
                seq = read_sequence(paths[row["name"]], orientation="device")
                row["evidence"] = orientation_evidence(phone_only(seq) if args.phone_only else seq).to_json()
    else:
        model = None if args.checkpoint is None else load_model(args.checkpoint)
        rows = []
        for dataset, path in validation_recordings(args.data_root):
            rows.append(study_row(dataset, path, model, args.phone_only))
            print(f"{rows[-1]['name']}: {json.dumps(rows[-1]['evidence'])}", flush=True)
    for row in rows:
        apply_rule(row)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(rows, indent=1))
    errors = "\n".join(error_table(rows))
    if args.phone_only:
        full = {r["name"]: r for r in json.loads(args.compare.read_text())} if args.compare else None
        ok = full is not None and all("ate" in r["vqf"] for r in rows)
        ates = "\n".join(phone_ate_table(rows, full)) if ok else None
    else:
        ates = "\n".join(ate_table(rows)) if all("ate" in r["device"] for r in rows) else None
    print(errors, ates or "", sep="\n\n")
    if args.out is not None:
        prefix = "phone-" if args.phone_only else ""
        replace_between(args.out, f"{prefix}sources", errors)
        if ates is not None:
            replace_between(args.out, f"{prefix}ate", ates)


if __name__ == "__main__":
    main()
