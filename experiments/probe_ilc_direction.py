"""Why the default's direction wanders from window to window on the ILC mall walks (issue 54 / 50).

The baseline (``probe_ilc_baseline``) found per-window speed about right but the direction of
consecutive window velocities cancelling (the mean of 1 s of windows keeps 0.76-0.86 of their speed).
This probe tests, on floors F1-F3 only (B1 and F4 are held out for the end), with OxIOD's hand-held
validation walk beside (``handheld/data1/syn/imu3.csv``, which reads right):

1. the data path: the sample clock (interval spread, repeated ticks), gravity in the prepared world
   frame (+z, about 9.8), the horizontal and vertical specific force after gravity, the gyroscope
   against the accelerometer in the device frame (the gravity direction, low-passed, must turn as
   ``dg/dt = g x omega``: the correlation of the two at the best lag and the lag itself, the sign
   saying whether an axis or the gyro's sign is flipped), and the attitude's yaw rate against the
   world-frame gyro z (``vqf``'s yaw must follow the gyro's integral);
2. the looks: the network run on every window at each fixed quarter turn of its world-frame input (one
   look, all windows at the same turn, velocity turned back), the four averaged (``yaw_copies=4``), and
   the default (window k at ``k mod 4`` quarter turns, ``ftin.yaw_average.cyclic_angles``). Per walk:
   coherence (|mean of 5 consecutive window velocities| / their mean speed, median over the walk), the
   median window speed, the path ratio (integrated like ``ftin.infer``, without the body lock, which
   the baseline found changes nothing here) and how far the four looks of one window disagree (the
   mean angle of each turned-back look from their mean direction);
3. whether the direction follows the phone: Spearman of the change of predicted direction between
   consecutive windows (0.2 s) against the change of the device yaw and against the world gyro z
   integrated over the same stride; at the waypoint corners turning more than 45 deg, whether the
   attitude's yaw and the predicted path (one look) turn the same way as the marks' polyline; and the
   phone's heading at the four looks' mean speed (``ftin.body_heading``'s lock, forced on);
4. the bounce: the looks' spread with the vertical specific force's swing about gravity halved.

    nice -n 10 python -m experiments.probe_ilc_direction --every 10          # F1-F3, beside OxIOD, RIDI
    nice -n 10 python -m experiments.probe_ilc_direction --every 10 --floors B1 F4 --ridi 0  # held out
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation
from scipy.stats import spearmanr

from experiments.common import argument_parser, hidden_walk_paths, parse, write_report
from ftin.body_heading import gait_forward, phone_heading, span_heading, steadiness
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.discovery import read_sequence
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence, Trajectory
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import integrate_windows, run_windows
from ftin.metrics.umeyama import fit_se2
from ftin.metrics.waypoints import marks_inside, positions_at, score_waypoints, turn_angles_rad
from ftin.yaw_average import turn_velocities

DIAGNOSE_FLOORS = ("F1", "F2", "F3")
OXIOD_WALKS = ("handheld/data1/syn/imu3.csv", "handheld/data1/syn/imu2.csv", "handheld/data1/syn/imu4.csv")
TURNS = (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
HALF_BOUNCE = 0.5  # the gain on the vertical specific force's swing in the bounce test
COHERENCE_WINDOWS = 5  # 1 s of windows at the default's 0.2 s stride


def turned_imu(imu: np.ndarray, angle: float) -> np.ndarray:
    """``(N, 6)`` world-frame gyro and acc turned about the vertical by ``angle``."""
    c, s = round(math.cos(angle), 12), round(math.sin(angle), 12)
    out = imu.copy()
    for i, j in ((0, 1), (3, 4)):
        out[:, i] = c * imu[:, i] - s * imu[:, j]
        out[:, j] = s * imu[:, i] + c * imu[:, j]
    return out


def looks(model: LoadedModel, imu: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """``(4, M, 2)`` each window's velocity with the input at each of ``TURNS``, turned back."""
    out = []
    for angle in TURNS:
        v, _ = run_windows(model, turned_imu(imu, angle), starts, model.window, 1, 512, None, False)
        out.append(turn_velocities(v[:, 0, :2], np.full(len(starts), -angle)))
    return np.stack(out)


def look_spread(per_turn: np.ndarray) -> float:
    """Median over windows of the mean angle (deg) of each look from the looks' mean direction."""
    mean = per_turn.mean(0)
    direction = np.arctan2(mean[:, 1], mean[:, 0])
    off = [np.abs(np.angle(np.exp(1j * (np.arctan2(v[:, 1], v[:, 0]) - direction)))) for v in per_turn]
    return float(np.degrees(np.median(np.mean(off, axis=0))))


def speed_kept_mean(per_turn: np.ndarray) -> np.ndarray:
    """``(M, 2)`` the four looks' mean direction at their mean speed: still equivariant to the quarter
    turns (the direction turns, the speed does not), without the shortening of averaging vectors that
    disagree in direction."""
    mean = per_turn.mean(0)
    unit = mean / np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-9)
    return unit * np.linalg.norm(per_turn, axis=2).mean(0)[:, None]


def phone_locked(prepared, starts: np.ndarray, window: int, per_turn: np.ndarray) -> np.ndarray:
    """``(M, 2)`` ``ftin.body_heading``'s lock forced on: the four looks' mean speed along the phone's
    heading plus the gait's forward offset (a phone held flat in front turns with the walker)."""
    t = prepared.seq.t_s
    yaw = phone_heading(prepared.seq.q_world_device_wxyz)
    heading = span_heading(yaw, starts, starts + window)
    t_mid = 0.5 * (t[starts] + t[starts + window])
    speed = np.linalg.norm(per_turn, axis=2).mean(0)
    forward = gait_forward(prepared.imu_world[:, 3:6], yaw, prepared.rate_hz, t, t_mid)
    offset = np.angle(np.sum(speed * np.exp(1j * forward)))
    return speed[:, None] * np.column_stack([np.cos(heading + offset), np.sin(heading + offset)])


def coherence(v: np.ndarray, k: int = COHERENCE_WINDOWS) -> float:
    speed = np.linalg.norm(v, axis=1)
    if len(v) <= k:
        return float("nan")
    kept = [
        np.linalg.norm(v[i : i + k].mean(0)) / max(speed[i : i + k].mean(), 1e-9) for i in range(len(v) - k)
    ]
    return float(np.median(kept))


def path_length(t_s: np.ndarray, p: np.ndarray, grid_s: float = 1.0) -> float:
    ticks = np.arange(t_s[0], t_s[-1], grid_s)
    xy = np.column_stack([np.interp(ticks, t_s, p[:, k]) for k in range(2)])
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


def path_scores(
    prepared_seq: ImuSequence, seq: ImuSequence, starts, window, v2: np.ndarray
) -> tuple[float, float]:
    """Predicted over true path and the ATE (one fitted 2-D rotation + translation) at the waypoints, or
    over the dense truth on a 1 s grid where there are no waypoints."""
    t_s, q = prepared_seq.t_s, prepared_seq.q_world_device_wxyz
    v = np.column_stack([v2, np.zeros(len(v2))])
    p = integrate_windows(t_s, starts, window, v, np.zeros(3))
    if seq.waypoints is None:
        truth = prepared_seq.gt
        if truth is None:
            return math.nan, math.nan
        ticks = np.arange(t_s[0], t_s[-1], 1.0)
        pred_xy = np.column_stack([np.interp(ticks, t_s, p[:, k]) for k in range(2)])
        true_xy = np.column_stack([np.interp(ticks, truth.t_s, truth.p_world_m[:, k]) for k in range(2)])
        residual = fit_se2(pred_xy, true_xy).apply(pred_xy) - true_xy
        ate = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
        return path_length(t_s, p) / path_length(truth.t_s, truth.p_world_m), ate
    metrics = score_waypoints(Trajectory(t_s, p, q), seq.waypoints)
    ratio = math.nan if metrics.path_ratio is None else float(metrics.path_ratio)
    return ratio, math.nan if metrics.ate_m is None else float(metrics.ate_m)


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float) -> np.ndarray:
    return sosfiltfilt(butter(2, cutoff_hz, fs=rate_hz, output="sos"), x, axis=0)


def gyro_vs_accel(seq: ImuSequence) -> tuple[float, int]:
    """Correlation of the measured turn of the gravity direction (device frame, acc low-passed at 1 Hz)
    with the gyro's prediction ``g x omega``, at the best lag (samples, gyro later = positive) in
    +-10 samples; and that lag. About +1: axes and sign agree; negative: a flipped sign or axis."""
    rate = seq.rate_hz
    g = lowpass(seq.acc_m_s2, rate, 1.0)
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    measured = np.gradient(g, axis=0) * rate
    predicted = np.cross(g, lowpass(seq.gyro_rad_s, rate, 1.0))
    best = (-2.0, 0)
    for lag in range(-10, 11):
        a = measured[max(0, -lag) : len(g) - max(0, lag)]
        b = predicted[max(0, lag) : len(g) - max(0, -lag)]
        r = float(np.corrcoef(a.ravel(), b.ravel())[0, 1])
        best = max(best, (r, lag))
    return best


def yaw_of(q_wxyz: np.ndarray) -> np.ndarray:
    """Unwrapped yaw (rad) of the attitude (z-y-x Euler angles)."""
    rot = Rotation.from_quat(q_wxyz[:, [1, 2, 3, 0]])
    return np.unwrap(rot.as_euler("ZYX")[:, 0])


def data_path_row(name: str, seq: ImuSequence, model: LoadedModel) -> dict:
    raw_dt = np.diff(seq.t_s)
    prepared = prepare(seq, model.imu_rate_hz, model.window, model.stride)
    world = prepared.seq
    imu = prepared.imu_world.astype(np.float64)
    acc_w = imu[:, 3:6]
    r, lag = gyro_vs_accel(seq)
    yaw = yaw_of(world.q_world_device_wxyz)
    yaw_rate = np.gradient(yaw) * prepared.rate_hz
    yaw_r = float(
        np.corrcoef(lowpass(yaw_rate, prepared.rate_hz, 2.0), lowpass(imu[:, 2], prepared.rate_hz, 2.0))[0, 1]
    )
    gyro_turn = float(np.sum(imu[:, 2]) / prepared.rate_hz)
    horizontal = acc_w[:, :2] - acc_w[:, :2].mean(0)
    return {
        "name": name,
        "rate": 1.0 / float(np.median(raw_dt)),
        "dt_spread": float(np.percentile(raw_dt, 99) / np.median(raw_dt)),
        "repeats": int(np.sum(raw_dt <= 0)),
        "g_z": float(acc_w[:, 2].mean()),
        "g_h": float(np.linalg.norm(acc_w[:, :2].mean(0))),
        "h_rms": float(np.sqrt(np.mean(np.sum(horizontal**2, axis=1)))),
        "v_rms": float(np.std(acc_w[:, 2])),
        "gyro_acc_r": r,
        "gyro_acc_lag": lag,
        "yaw_r": yaw_r,
        "yaw_vs_gyro_deg": float(np.degrees(yaw[-1] - yaw[0])),
        "gyro_int_deg": float(np.degrees(gyro_turn)),
        "filter": world.meta.get("orientation_filter"),
    }


def walk_row(name: str, seq: ImuSequence, model: LoadedModel) -> dict:
    prepared = prepare(seq, model.imu_rate_hz, model.window, model.stride)
    imu, starts, t_s = prepared.imu_world, prepared.starts, prepared.seq.t_s
    q = prepared.seq.q_world_device_wxyz
    per_turn = looks(model, imu, starts)  # (4, M, 2)
    cyclic = per_turn[np.arange(len(starts)) % 4, np.arange(len(starts))]
    mean4 = per_turn.mean(0)
    modes = {
        "cyclic (default)": cyclic,
        "mean of 4": mean4,
        "4: mean direction, mean speed": speed_kept_mean(per_turn),
        "phone heading, 4-look speed": phone_locked(prepared, starts, model.window, per_turn),
        **{f"look {k * 90}": per_turn[k] for k in range(4)},
    }
    row: dict = {"name": name}
    for label, v in modes.items():
        ratio, ate = path_scores(prepared.seq, seq, starts, model.window, v)
        row[label] = {
            "coherence": coherence(v),
            "speed": float(np.median(np.linalg.norm(v, axis=1))),
            "ratio": ratio,
            "ate": ate,
        }
    t_mid = 0.5 * (t_s[starts] + t_s[starts + model.window])
    phone = span_heading(phone_heading(q), starts, starts + model.window)
    row["steadiness"] = float(np.median(steadiness(cyclic, phone, t_mid)))
    row["look_spread_deg"] = look_spread(per_turn)
    half = imu.copy()  # the vertical specific force's swing about gravity halved
    half[:, 5] = half[:, 5].mean() + HALF_BOUNCE * (half[:, 5] - half[:, 5].mean())
    half_looks = looks(model, half, starts)
    row["half_bounce_spread_deg"] = look_spread(half_looks)
    row["half_bounce_speed"] = float(np.median(np.linalg.norm(half_looks, axis=2).mean(0)))
    row["v_rms"] = float(np.std(imu[:, 5]))
    # Does the direction follow the phone? Window-to-window changes, one look (turn 0).
    v0 = per_turn[0]
    d_pred = np.angle(np.exp(1j * np.diff(np.arctan2(v0[:, 1], v0[:, 0]))))
    centre = starts + model.window // 2
    yaw = yaw_of(q)
    d_yaw = np.diff(yaw[centre])
    gz = np.cumsum(imu[:, 2].astype(np.float64)) / prepared.rate_hz
    d_gyro = np.diff(gz[centre])
    row["rho_yaw"] = float(spearmanr(d_pred, d_yaw).statistic)
    row["rho_gyro"] = float(spearmanr(d_pred, d_gyro).statistic)
    row["median_dpred_deg"] = float(np.degrees(np.median(np.abs(d_pred))))
    row.update(turn_signs(seq, t_s, yaw, per_turn[0], starts, model.window))
    return row


def turn_signs(seq: ImuSequence, t_s: np.ndarray, yaw: np.ndarray, v0, starts, window) -> dict:
    """At waypoint corners turning more than 45 deg: how many the attitude's yaw (segment middle to
    segment middle) and the predicted path (one look) turn the same way as the marks' polyline. A
    mirrored frame (a flipped axis) turns them all the wrong way."""
    if seq.waypoints is None:
        return {"corners": 0, "yaw_same_sign": 0, "path_same_sign": 0}
    v = np.column_stack([v0, np.zeros(len(v0))])
    trajectory = Trajectory(t_s, integrate_windows(t_s, starts, window, v, np.zeros(3)), None)
    marks = marks_inside(trajectory, seq.waypoints)
    d_true = np.diff(marks.xy_map_m, axis=0)
    d_pred = np.diff(positions_at(trajectory, marks.t_s), axis=0)
    middles = 0.5 * (marks.t_s[1:] + marks.t_s[:-1])
    yaw_mid = np.interp(middles, t_s, yaw)
    corners = yaw_same = path_same = 0
    for k in range(len(d_true) - 1):
        true_turn = float(turn_angles_rad(d_true[k : k + 2])[0])
        if abs(true_turn) < math.radians(45):
            continue
        corners += 1
        yaw_same += int(np.sign(yaw_mid[k + 1] - yaw_mid[k]) == np.sign(true_turn))
        path_same += int(np.sign(turn_angles_rad(d_pred[k : k + 2])[0]) == np.sign(true_turn))
    return {"corners": corners, "yaw_same_sign": yaw_same, "path_same_sign": path_same}


MODES = (
    "cyclic (default)",
    "mean of 4",
    "4: mean direction, mean speed",
    "phone heading, 4-look speed",
    "look 0",
    "look 90",
    "look 180",
    "look 270",
)


def med(rows: list[dict], key) -> float:
    values = [v for v in (key(r) for r in rows) if np.isfinite(v)]
    return float(np.median(values)) if values else float("nan")


def mode_table(groups: dict[str, list[dict]]) -> list[str]:
    lines = [
        "| group | walks | look | coherence (1 s) | window speed (m/s) | path ratio | in 0.85-1.15 "
        "| ATE (m, median; ILC at the waypoints, else on a 1 s grid) |",
        "|---|--:|---|--:|--:|--:|--:|--:|",
    ]
    for group, rows in groups.items():
        for mode in MODES:
            ratios = [r[mode]["ratio"] for r in rows if np.isfinite(r[mode]["ratio"])]
            band = f"{sum(0.85 <= x <= 1.15 for x in ratios)} of {len(ratios)}" if ratios else "-"
            ratio = f"{np.median(ratios):.2f}" if ratios else "-"
            lines.append(
                f"| {group} | {len(rows)} | {mode} | {med(rows, lambda r, m=mode: r[m]['coherence']):.2f} "
                f"| {med(rows, lambda r, m=mode: r[m]['speed']):.2f} | {ratio} | {band} "
                f"| {med(rows, lambda r, m=mode: r[m]['ate']):.2f} |"
            )
    return lines


def phone_table(groups: dict[str, list[dict]]) -> list[str]:
    lines = [
        "| group | walks | steadiness (default) | look spread (deg) | rho(d direction, d yaw) "
        "| rho(d direction, gyro z) "
        "| median abs. change of direction per 0.2 s (deg) | corners > 45 deg | yaw turns the same way "
        "| path turns the same way | look spread at half bounce (deg) | 4-look speed at half bounce |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for group, rows in groups.items():
        lines.append(
            f"| {group} | {len(rows)} | {med(rows, lambda r: r['steadiness']):.2f} "
            f"| {med(rows, lambda r: r['look_spread_deg']):.0f} "
            f"| {med(rows, lambda r: r['rho_yaw']):.2f} | {med(rows, lambda r: r['rho_gyro']):.2f} "
            f"| {med(rows, lambda r: r['median_dpred_deg']):.0f} | {sum(r['corners'] for r in rows)} "
            f"| {sum(r['yaw_same_sign'] for r in rows)} | {sum(r['path_same_sign'] for r in rows)} "
            f"| {med(rows, lambda r: r['half_bounce_spread_deg']):.0f} "
            f"| {med(rows, lambda r: r['half_bounce_speed']):.2f} |"
        )
    return lines


def data_table(groups: dict[str, list[dict]]) -> list[str]:
    keys = (
        "rate",
        "dt_spread",
        "repeats",
        "g_z",
        "g_h",
        "h_rms",
        "v_rms",
        "gyro_acc_r",
        "gyro_acc_lag",
        "yaw_r",
    )
    lines = [
        "| group | walks | rate (Hz) | p99 / median interval | repeated ticks | world g z (m/s²) "
        "| world g horizontal | horizontal acc rms | vertical acc rms | gyro-acc r | lag (samples) "
        "| r(attitude yaw rate, world gyro z) | net turn: attitude vs gyro integral (median gap) |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|",
    ]
    for group, rows in groups.items():
        cells = " | ".join(f"{med(rows, lambda r, k=k: r[k]):.3g}" for k in keys)
        gap = [abs(r["yaw_vs_gyro_deg"] - r["gyro_int_deg"]) / max(abs(r["gyro_int_deg"]), 1.0) for r in rows]
        lines.append(f"| {group} | {len(rows)} | {cells} | {100 * np.median(gap):.1f} % |")
    return lines


def bounce_lines(groups: dict[str, list[dict]]) -> list[str]:
    ilc = [r for group, rows in groups.items() if group.startswith("ILC") for r in rows]
    if len(ilc) < 3:
        return []
    rho = spearmanr([r["v_rms"] for r in ilc], [r["look_spread_deg"] for r in ilc])
    rho_ratio = spearmanr([r["v_rms"] for r in ilc], [r["cyclic (default)"]["ratio"] for r in ilc])
    return [
        f"Over the {len(ilc)} ILC walks: Spearman(vertical acc rms, look spread) {rho.statistic:.2f} "
        f"(p {rho.pvalue:.3f}); Spearman(vertical acc rms, default path ratio) {rho_ratio.statistic:.2f} "
        f"(p {rho_ratio.pvalue:.3f})."
    ]


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ronin_resnet-walking"))
    parser.add_argument("--every", type=int, default=10, help="every k-th trace of each floor")
    parser.add_argument("--floors", nargs="+", default=list(DIAGNOSE_FLOORS))
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--ridi", type=int, default=4, help="the first k RIDI validation walks beside")
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    model = load_model(args.checkpoint)
    started = time.monotonic()
    walks: dict[str, list[Path]] = {
        f"ILC {floor}": sorted((args.data_root / "ilc" / "site1" / floor).glob("*.txt.xz"))[:: args.every]
        for floor in args.floors
    }
    walks["OxIOD hand-held"] = [args.data_root / "oxiod" / w for w in OXIOD_WALKS]
    if args.ridi > 0:
        walks["RIDI validation"] = hidden_walk_paths(args.data_root, "ridi")[: args.ridi]
    data_rows: dict[str, list[dict]] = {}
    walk_rows: dict[str, list[dict]] = {}
    for group, paths in walks.items():
        for path in paths:
            seq = read_sequence(path)
            data_rows.setdefault(group, []).append(data_path_row(path.stem, seq, model))
            walk_rows.setdefault(group, []).append(walk_row(path.stem, seq, model))
        print(mode_table({group: walk_rows[group]})[2], flush=True)
    minutes = (time.monotonic() - started) / 60
    lines = [
        f"# Why the direction wanders on the ILC walks (`{args.checkpoint}`, "
        f"floors {', '.join(args.floors)})",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_ilc_direction --every {args.every} "
        f"--floors {' '.join(args.floors)}` ({minutes:.0f} min on two shared cores); method: its docstring. "
        "OxIOD and RIDI rows: path ratio and ATE (one 2-D rotation + translation) over their dense truth "
        "on a 1 s grid.",
        "",
        "## The data path",
        "",
        *data_table(data_rows),
        "",
        "## The looks",
        "",
        *mode_table(walk_rows),
        "",
        "## Does the direction follow the phone (one look, turn 0)?",
        "",
        *phone_table(walk_rows),
        "",
        *bounce_lines(walk_rows),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
