"""Does one walk of known length teach a walker's stride? (issue 54, item 4: profiles.)

Question: the default model reads distance short on new walkers and carries by a factor that holds
over the whole walk. A profile (``ftin.profiles``) learns that factor from walks whose length is known
(a measured route, good GPS). Does one such walk bring the same walker's *other* walks of the same
carry into a path ratio of 0.85-1.15 on at least 80 % (the issue's done-when clause)?

Method: every walk of a (walker, carry) group with two or more walks, OxIOD and RIDI, read as a phone
alone gives it (``load_phone_only``) by the default model and scored as the acceptance check scores
(``ftin.evaluate.score``: predicted / true horizontal path over the model's window). Each walk in turn
is the profile's one walk (its scale = true / predicted path, what ``POST /profiles/{name}/walks``
with ``distance_m`` records); every other walk of its group is scored before (its own ratio) and after
(its ratio times that scale, what ``POST /predict?profile=`` applies). The share in band counts these
(profile walk, other walk) pairs. Walks the default model trained on are marked, and the held-out
pairs (the scored walk held out of training) are counted apart.

Also measured: the spread of the log-scale between walks of one group (pooled over groups), beside
the prior spread a one-walk profile states (``ftin.profiles.scale.ONE_WALK_LOG_SPREAD``); how a profile
of every other walk of the group does (leave-one-out, the median of the log-scales); and whether the
95 % end radius still holds the true end when the speed-scale term takes the profile's spread instead
of the population's, at each floor of ``FLOORS``: the smallest floor that holds ``COVERAGE_AIM`` of the
pairs is ``ftin.profiles.scale.SCALE_SIGMA_FLOOR`` (fitted here: no walk is held out from it).

Predictions are cached per walk (``--cache``, keyed by the checkpoint's weights): a rerun takes
seconds.

    python -m experiments.probe_profile_scale --out docs/results/probes/profile_scale.md
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from experiments.common import argument_parser, parse, weights_key, write_report
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only
from ftin.data.types import Trajectory
from ftin.evaluate import score
from ftin.files import DEFAULT_CHECKPOINT_DIR, DEFAULT_DATA_ROOT, write_json
from ftin.infer import Prediction, predict_trajectory
from ftin.profiles.scale import (
    ONE_WALK_LOG_SPREAD,
    SCALE_SIGMA_FLOOR,
    ProfileScale,
    apply_scale,
    profile_scale,
)
from ftin.uncertainty import uncertainty_of
from ftin.uncertainty.coverage import coverage_of

BAND = (0.85, 1.15)
FLOORS = (0.0, 0.1, 0.2, 0.25, 0.28, 0.3, 0.32, 0.35)  # speed-scale floors whose end coverage is measured
COVERAGE_AIM = 0.85  # the floor chosen: the smallest whose one-walk profiles hold the end this often
OX = "oxiod"
U3, U4, IP6, FLOOR = (
    "multi users/user3/syn",
    "multi users/user4/syn",
    "multi devices/iPhone 6/syn",
    "large scale/floor1/syn",
)


def _walks(folder: str, numbers: tuple[int, ...] | range, suffix: str = ".csv.xz") -> tuple[str, ...]:
    return tuple(f"{folder}/imu{i}{suffix}" for i in numbers)


# (dataset, group label, walks relative to the dataset's folder): the groups of two or more walks of
# one walker and one carry. Where the release does not document the carry (user4, the iPhone 6, the
# floor1 walks), it is told by the signal (``SIGNAL_NOTE``; the figures are in the report): the walks
# fall into the release's own numbering (user3's Readme: hand-held, then pocket, then handbag).
GROUPS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    (OX, "oxiod user1 hand-held", _walks("handheld/data1/syn", (2, 3, 4), ".csv")),
    (OX, "oxiod user2 hand-held", _walks("multi users/user2/syn", (4, 5, 6), ".csv")),
    (OX, "oxiod user3 pocket", _walks(U3, (4, 5))),
    (OX, "oxiod user4 pocket (by signal)", _walks(U4, (4, 6))),
    (OX, "oxiod iPhone 6 hand-held (by signal)", _walks(IP6, (1, 2, 3))),
    (OX, "oxiod iPhone 6 pocket (by signal)", _walks(IP6, (4, 5, 6))),
    (OX, "oxiod iPhone 6 handbag (by signal)", _walks(IP6, (7, 8, 9))),
    (OX, "oxiod Nexus 5 hand-held", _walks("multi devices/nexus 5/syn", (7, 8))),
    (OX, "oxiod running (in hand)", _walks("running/data1/syn", (6, 7))),
    (OX, "oxiod floor1 hand-held (by signal)", _walks(FLOOR, (1, 2, 3))),
    (OX, "oxiod floor1 pocket (by signal)", _walks(FLOOR, (4, 5, 6))),
    (OX, "oxiod floor1 handbag (by signal)", _walks(FLOOR, (7, 8, 9, 10))),
    ("ridi", "ridi dan bag", ("dan_bag1", "dan_bag2")),
    ("ridi", "ridi dan body", ("dan_body1", "dan_body2", "dan_body3")),
    ("ridi", "ridi dan hand-held", ("dan_handheld1", "dan_handheld2")),
    ("ridi", "ridi hang body", ("hang_body_fast1", "hang_body_test1")),
    ("ridi", "ridi hao body", ("hao_body1", "hao_body2")),
    ("ridi", "ridi ma body", ("ma_body1", "ma_body2")),
)
SIGNAL_NOTE = (
    "Carry by signal: held flat in front when gravity lies along the screen's normal (|g_z| > 0.7 of "
    "the mean specific force's direction in the device frame); upright (gravity along the device's y) "
    "in a pocket when the phone turns with the leg (mean |gyro| near 1 rad/s, the larger bounce), in a "
    "handbag when it turns and bounces less."
)


def walk_lengths(checkpoint: Path, data_root: Path, cache: Path) -> dict[str, dict]:
    """Each walk's predicted and true path (m), predicted once and kept in ``cache``."""
    model = load_model(checkpoint)
    file = cache / weights_key(model) / "walks.json"
    rows: dict[str, dict] = json.loads(file.read_text()) if file.exists() else {}
    trained = set((model.meta.get("training_data") or {}).get("recordings", []))
    for dataset, _label, walks in GROUPS:
        for rel in walks:
            key = f"{dataset}/{rel}"
            if key in rows and prediction_file(cache / weights_key(model), key).exists():
                continue
            (seq,) = load_phone_only([data_root / dataset / rel])
            prediction = predict_trajectory(model, seq, keep_prepared=False)
            metrics = score(prediction).metrics
            save_prediction(prediction_file(cache / weights_key(model), key), prediction)
            rows[key] = {
                "predicted_m": metrics.predicted_path_m,
                "true_m": metrics.true_path_m,
                "minutes": seq.duration_s / 60,
                "trained": key in trained,
                **carry_signal(seq),
            }
            print(f"{key}: {metrics.predicted_path_m:.1f} m of {metrics.true_path_m:.1f} m")
            write_json(file, rows)  # after every walk: an interrupted run keeps what it read
    return rows


def prediction_file(folder: Path, key: str) -> Path:
    return folder / f"{re.sub(r'[^A-Za-z0-9_.-]+', '_', key)}.npz"


def save_prediction(file: Path, prediction: Prediction) -> None:
    """What the uncertainty of a scaled prediction needs (``load_prediction`` makes it again)."""
    log_std = (prediction.features or {}).get("log_std")
    np.savez(
        file,
        t_s=prediction.trajectory.t_s,
        p=prediction.trajectory.p_world_m,
        truth_p=prediction.truth.p_world_m,
        window_t_s=prediction.window_t_s,
        velocity=prediction.velocity_m_s,
        spans=prediction.span_t_s,
        log_std=np.zeros((0, 2)) if log_std is None else np.asarray(log_std, dtype=np.float64),
        orientation_filter=np.array(str(prediction.orientation_filter)),
        window_s=np.array(prediction.window_s),
    )


def load_prediction(file: Path) -> Prediction:
    with np.load(file) as d:
        features = {"log_std": d["log_std"]} if len(d["log_std"]) else None
        return Prediction(
            trajectory=Trajectory(d["t_s"], d["p"]),
            window_t_s=d["window_t_s"],
            velocity_m_s=d["velocity"],
            orientation_source="device",
            frame="device_world",
            warnings=[],
            features=features,
            span_t_s=d["spans"],
            truth=Trajectory(d["t_s"], d["truth_p"]),
            window_s=float(d["window_s"]),
            orientation_filter=str(d["orientation_filter"]),
        )


def carry_signal(seq) -> dict[str, float]:
    """What tells a carry apart (``SIGNAL_NOTE``): gravity's direction in the device frame (the mean
    specific force's), the bounce (std of |acc|, m/s^2) and the mean |gyro| (rad/s)."""
    acc = np.asarray(seq.acc_m_s2, dtype=np.float64)
    g = acc.mean(axis=0) / np.linalg.norm(acc.mean(axis=0))
    return {
        "gravity_y": float(g[1]),
        "gravity_z": float(g[2]),
        "bounce": float(np.linalg.norm(acc, axis=1).std()),
        "gyro": float(np.linalg.norm(seq.gyro_rad_s, axis=1).mean()),
    }


def in_band(ratio: float) -> bool:
    return BAND[0] <= ratio <= BAND[1]


def group_rows(rows: dict[str, dict]) -> tuple[list[dict], dict[str, list]]:
    """Per group: before / after shares (one walk and leave-one-out); the pooled pair lists."""
    table, pooled = [], defaultdict(list)
    for dataset, label, walks in GROUPS:
        keys = [f"{dataset}/{rel}" for rel in walks]
        ratio = {k: rows[k]["predicted_m"] / rows[k]["true_m"] for k in keys}
        pairs = [(p, o) for p in keys for o in keys if p != o]
        before = [in_band(ratio[o]) for _, o in pairs]
        after = [in_band(ratio[o] / ratio[p]) for p, o in pairs]
        held = [(p, o) for p, o in pairs if not rows[o]["trained"]]
        loo = [in_band(ratio[o] * profile_scale([1 / ratio[k] for k in keys if k != o]).scale) for o in keys]
        logs = np.log([1 / ratio[k] for k in keys])
        pooled["before"] += before
        pooled["after"] += after
        pooled["held_before"] += [in_band(ratio[o]) for _, o in held]
        pooled["held_after"] += [in_band(ratio[o] / ratio[p]) for p, o in held]
        pooled["loo"] += loo
        pooled["deviations"] += list(logs - logs.mean())
        pooled["dof"].append(len(keys) - 1)
        table.append({
            "label": label, "walks": len(keys), "trained": sum(rows[k]["trained"] for k in keys),
            "ratios": [ratio[k] for k in keys], "before": np.mean(before), "after": np.mean(after),
            "held_pairs": len(held), "loo": np.mean(loo), "log_std": float(np.std(logs, ddof=1)),
        })  # fmt: skip
    return table, pooled


def report(rows: dict[str, dict], checkpoint: Path) -> list[str]:
    table, pooled = group_rows(rows)
    share = {k: float(np.mean(v)) for k, v in pooled.items() if k not in ("deviations", "dof")}
    count = {k: len(v) for k, v in pooled.items() if k not in ("deviations", "dof")}
    spread = float(np.sqrt(np.sum(np.square(pooled["deviations"])) / np.sum(pooled["dof"])))
    groups_met = sum(r["after"] >= 0.8 for r in table)
    lines = [
        "# One walk of known length: a walker's own stride (issue 54, item 4)",
        "",
        f"Checkpoint `{checkpoint.stem}` (the default), phone only (`load_phone_only`), path ratio = "
        "predicted / true horizontal path over the model's window (`ftin.evaluate.score`). Each walk of a "
        "group is in turn the profile's one walk (scale = its true / predicted path); every other walk "
        f"of the group is scored before and after that scale. In band: {BAND[0]}-{BAND[1]}. "
        "Made by `python -m experiments.probe_profile_scale --out docs/results/probes/profile_scale.md`.",
        "",
        "| group | walks (trained on) | path ratio of each walk | in band before | after one walk | "
        "held-out pairs | leave-one-out profile | log-scale std |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in table:
        ratios = " ".join(f"{x:.2f}" for x in r["ratios"])
        lines.append(
            f"| {r['label']} | {r['walks']} ({r['trained']}) | {ratios} | {r['before']:.0%} | "
            f"{r['after']:.0%} | {r['held_pairs']} | {r['loo']:.0%} | {r['log_std']:.3f} |"
        )
    lines += [
        "",
        "## Pooled",
        "",
        f"- all pairs ({count['before']}): in band {share['before']:.0%} before, **{share['after']:.0%} "
        "after one walk**",
        f"- pairs whose scored walk the default model never trained on ({count['held_before']}): "
        f"{share['held_before']:.0%} before, **{share['held_after']:.0%} after**",
        f"- leave-one-out profile (median of the group's other log-scales, {count['loo']} walks): "
        f"{share['loo']:.0%}",
        f"- groups with at least 80 % of pairs in band after one walk: {groups_met} of {len(table)}",
        f"- spread of the log-scale between walks of one group (pooled, {int(np.sum(pooled['dof']))} "
        f"degrees of freedom): {spread:.3f}; the one-walk prior in `ftin.profiles.scale` is "
        f"{ONE_WALK_LOG_SPREAD:.3f}",
        "",
        "The iPhone 6, Nexus 5 and floor1 folders do not name their walker: each folder is taken as one "
        "walker's. Running is a gait, not a carry. " + SIGNAL_NOTE,
        "",
        "| walk | path ratio | gravity y, z (device frame) | bounce m/s^2 | mean gyro rad/s |",
        "|---|---|---|---|---|",
    ]
    for dataset, label, walks in GROUPS:
        if "by signal" in label:
            for rel in walks:
                r = rows[f"{dataset}/{rel}"]
                lines.append(
                    f"| {rel} | {r['predicted_m'] / r['true_m']:.2f} | {r['gravity_y']:.2f}, "
                    f"{r['gravity_z']:.2f} | {r['bounce']:.2f} | {r['gyro']:.2f} |"
                )
    return lines


def coverage_lines(rows: dict[str, dict], folder: Path, checkpoint: str) -> list[str]:
    """Does the 95 % end radius hold the true end, without a profile and with one walk's profile at
    each floor of ``FLOORS``: the share of (profile walk, other walk) pairs, start-aligned."""
    plain, by_floor, pair_plain, pair_population = [], defaultdict(list), [], []
    for dataset, _label, walks in GROUPS:
        keys = [f"{dataset}/{rel}" for rel in walks]
        predictions = {k: load_prediction(prediction_file(folder, k)) for k in keys}
        for other in keys:
            pred = predictions[other]
            found = uncertainty_of(pred, checkpoint)
            plain.append(coverage_of(pred.trajectory, found.cov_m2, pred.truth, found.end_radius_95_m))
            alone = plain[-1]
            for walk in (k for k in keys if k != other):
                scaled = apply_scale(pred, rows[walk]["true_m"] / rows[walk]["predicted_m"])
                pair_plain.append(alone)  # the same pairs without a profile: weighted alike
                found = uncertainty_of(scaled, checkpoint)  # scaled, the population's spread kept
                pair_population.append(
                    coverage_of(scaled.trajectory, found.cov_m2, scaled.truth, found.end_radius_95_m)
                )
                for floor in FLOORS:
                    sigma = max(ProfileScale(1.0, ONE_WALK_LOG_SPREAD, 1).spread_sigma, floor)  # one walk's
                    found = uncertainty_of(scaled, checkpoint, scale_sigma=sigma)
                    by_floor[floor].append(
                        coverage_of(scaled.trajectory, found.cov_m2, scaled.truth, found.end_radius_95_m)
                    )

    def line(what: str, found: list) -> str:
        found = [c for c in found if c is not None]
        radius = np.array([c.end_radius_95_m for c in found])
        error = np.array([c.end_error_m for c in found])
        rho = spearmanr(radius, error).statistic
        inside = sum(c.end_inside for c in found)
        return (
            f"| {what} | {len(found)} | {inside} ({inside / len(found):.1%}) | {np.median(radius):.1f} | "
            f"{np.median(error):.1f} | "
            f"{rho:.2f} |"
        )

    lines = [
        "",
        "## The 95 % end radius with a profile",
        "",
        "The true end inside the 95 % radius (start-aligned, `ftin.uncertainty.coverage`), without a "
        "profile (each walk once, all carries' speed-scale spread) and with the profile of one other walk "
        "of the group, whose speed-scale term then uses the profile's spread: the prior of one walk, "
        "widened by the mean's own error (`ProfileScale.spread_sigma`, prior x sqrt 2), at least a floor "
        "(`ProfileScale.scale_sigma`).",
        "",
        "| uncertainty | walks or pairs | true end inside | median radius m | median end error m | "
        "Spearman(radius, error) |",
        "|---|---|---|---|---|---|",
        line("no profile (each walk once)", plain),
        line("no profile (the pairs below, each walk once per profile walk)", pair_plain),
        line("one-walk profile's scale, the population's speed-scale spread kept", pair_population),
    ]
    lines += [
        line(
            f"one-walk profile, its spread ({ONE_WALK_LOG_SPREAD:.2f} x sqrt 2) floored at {floor:.2f}",
            by_floor[floor],
        )
        for floor in FLOORS
    ]
    inside = {f: np.mean([c.end_inside for c in by_floor[f] if c is not None]) for f in FLOORS}
    chosen = min((f for f in FLOORS if inside[f] >= COVERAGE_AIM), default=None)
    lines += [
        "",
        f"The smallest floor whose one-walk profiles hold the true end on at least {COVERAGE_AIM:.0%} of "
        f"pairs: **{chosen}** (`ftin.profiles.scale.SCALE_SIGMA_FLOOR` is {SCALE_SIGMA_FLOOR}). "
        "Fitted on these pairs: no walk here is held out from this choice.",
    ]
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT_DIR / "ronin_resnet-walking")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--cache", type=Path, default=Path("runs/profile_scale"), help="per-walk lengths")
    parser.add_argument("--out", type=Path, default=None, help="markdown report (default: print only)")
    args = parse(parser)
    rows = walk_lengths(args.checkpoint, args.data_root, args.cache)
    folder = args.cache / weights_key(load_model(args.checkpoint))
    write_report(args.out, report(rows, args.checkpoint) + coverage_lines(rows, folder, args.checkpoint.stem))


if __name__ == "__main__":
    main()
