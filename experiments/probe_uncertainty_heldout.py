"""Does the 95 % end radius cover walkers, carries and places the calibration never saw? (issue 54,
item 5.) Refit the speed-scale term and the covariance factor of ``ftin.uncertainty`` on groups the
network never trained on, and measure on other groups held out from every choice.

Question: ``experiments.probe_uncertainty`` fits its constants on the walker-held-out validation walks
(OxIOD, RIDI, Inria), which are walks like the training ones: there the true end lies within the 95 %
radius on 94 %, on the ILC mall walks (read at a path ratio of ~0.58) on far fewer. Fitted on groups
that include a new place, does the radius hold the true end on 85-98 % of held-out walks in each
held-out group, with Spearman(radius, end error) >= 0.5?

Groups (phone only, the default model ``checkpoints/ronin_resnet-walking``):

- **fit** (every choice below is made on these alone): the OxIOD and RIDI validation walks, the new
  OxIOD walks of the walkers the variance head trained on (``oxiod_new: heads' training walkers``: the
  velocity network never saw them; their window sigma is the head's training fit, so only the speed
  scale and the factor are read from them) and the ILC mall floors F1, F2, F3, every ``EVERY``-th
  trace (``experiments.uncertainty_ilc_walks``; sparse truth: the surveyor's waypoints). The network
  never trained on any of them; the planned retrain (item 2 of the issue) will use F1-F3 for
  training, as sparse truth only, so after it they are no longer unseen and this fit must move to
  floors it leaves out.
- **held out** from every choice: the Inria validation walks, the ILC floors B1 and F4 (every
  ``EVERY``-th trace), the new OxIOD walkers held out of stage three (``oxiod_new: held out``) and the
  long floor walks.

The window sigma (the head's ``log_std_scale``, ``a + b |v|``) and the heading terms are kept as
``experiments.probe_uncertainty`` fitted them (on the 34 validation walks, Inria's among them): they
describe per-window noise and heading, which the sparse ILC truth cannot measure.

Fitting rule (written before any held-out group was read; the fit groups were looked at: their
distance ratio follows the walk's direction coherence, ``ftin.uncertainty.propagate``, Spearman 0.84,
the ILC walks at ~0.8 and 0.59 of their distance, the dense ones at ~0.99 and ~0.9):

1. speed scale: one spread for every carry (the per-carry spreads are dropped: the fit groups hold
   too few pocket or swinging walks to measure one), ``(ratio - 1) ~ N(0, s0^2 + (g (1 - c))^2)``
   with ``c`` the walk's direction coherence: ``s0`` (``scale_sigma``) and ``g``
   (``coherence_gain``) by the Gaussian likelihood, grid search, **each fit group weighted alike**
   (the mean over a group's walks, summed over groups), so that the ILC walks do not outvote two
   OxIOD ones nor the other way round;
2. one factor on the position covariance so that the 2-sigma ellipse holds 86.5 % at 30 s, 60 s and
   the end, pooled over the fit groups with each group weighted alike (``experiments.probe_uncertainty``'s
   rule, weighted);
3. adopted (``--save``) where it brings more held-out groups into 85-98 % than before; the plain
   variant (``g = 0``: ``s0`` the group-weighted RMS of (ratio - 1), then the factor) is reported
   beside, not adopted.

End error of an ILC walk (sparse truth): after a start alignment the dense walks' way: the predicted
position at the first waypoint put on it and the path turned so that its displacement from the first
waypoint to the first one at least ``ALIGN_S`` later and ``ALIGN_M`` away points where the marks'
does (the first 10 s, as the dense walks' rigid fit over their first 10 s); the error is then read at
every waypoint, the end error at the last one, against the covariance at that waypoint's time. A
second reading turns the path by the SE(2) fit over all the walk's waypoints instead (what
``ftin.metrics.waypoints`` scores ATE with), still pinned at the first waypoint: reported beside.

Predictions are cached (``runs/uncertainty_walks``, ``runs/uncertainty_ilc``): a rerun takes a minute.

    python -m experiments.probe_uncertainty_heldout --save --out docs/results/probes/uncertainty_heldout.md
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from experiments.common import argument_parser, parse, weights_key, write_report
from experiments.probe_uncertainty import (
    CHECKPOINT,
    MARKS,
    TWO_SIGMA,
    _new_part,
    covariance,
    distance_ratio,
    marks_of,
)
from experiments.uncertainty_ilc_walks import cached_ilc_walks
from experiments.uncertainty_walks import NEW_SET, cached_walks
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.files import DEFAULT_DATA_ROOT
from ftin.metrics.umeyama import fit_se2
from ftin.uncertainty.calibration import Calibration, calibration_for, save_calibration
from ftin.uncertainty.propagate import direction_coherence
from ftin.uncertainty.radius import mahalanobis_sq, radius_holding

EVERY = 3  # every 3rd ILC trace of a floor, in file-name order
FIT_FLOORS, HELD_FLOORS = ("F1", "F2", "F3"), ("B1", "F4")
HEADS = f"{NEW_SET}: heads' training walkers"
FIT_GROUPS = (protocol.OXIOD, protocol.RIDI, HEADS, *(f"ilc {f}" for f in FIT_FLOORS))
HELD_GROUPS = (
    protocol.INRIA,
    *(f"ilc {f}" for f in HELD_FLOORS),
    f"{NEW_SET}: held out (stage three's validation)",
    f"{NEW_SET}: long floor walks",
)
ALIGN_S, ALIGN_M = 10.0, 2.0
PATH_GRID_S = 1.0  # the path ratio's grid (``ftin.metrics.waypoints``)


def group_of(w: dict) -> str:
    return _new_part(str(w["name"])) if str(w["dataset"]) == NEW_SET else str(w["dataset"])


def is_sparse(w: dict) -> bool:
    return "wp_t_s" in w


def _at(t: np.ndarray, p: np.ndarray, times: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(times, t, p[:, k]) for k in (0, 1)])


def _marks_inside(w: dict) -> tuple[np.ndarray, np.ndarray]:
    t, wt = w["t_s"], w["wp_t_s"]
    inside = (wt >= t[0] - 1.0) & (wt <= t[-1] + 1.0)  # ftin.metrics.waypoints.EDGE_TOLERANCE_S
    return wt[inside], w["wp_xy_m"][inside]


def path_ratio(w: dict) -> float:
    """Dense: predicted over true path; sparse: the predicted path between the first and last waypoint
    (1-s grid) over the waypoints' polyline (``ftin.metrics.waypoints``)."""
    if not is_sparse(w):
        return distance_ratio(w)
    wt, wx = _marks_inside(w)
    ticks = np.append(np.arange(wt[0], wt[-1], PATH_GRID_S), wt[-1])
    predicted = np.linalg.norm(np.diff(_at(w["t_s"], w["p_pred"], ticks), axis=0), axis=1).sum()
    return float(predicted / max(np.linalg.norm(np.diff(wx, axis=0), axis=1).sum(), 1e-9))


def sparse_errors(w: dict, rotation: str = "start") -> tuple[np.ndarray, np.ndarray]:
    """``(mark times, (K, 2) errors)`` of a waypoint walk after the start alignment (module
    docstring); ``rotation="se2"``: turned by the SE(2) fit over all marks instead."""
    wt, wx = _marks_inside(w)
    p = _at(w["t_s"], w["p_pred"], wt)
    if rotation == "se2":
        yaw = float(fit_se2(p, wx).R_gt_est.as_euler("zyx")[0])
    else:
        far = (wt - wt[0] >= ALIGN_S) & (np.linalg.norm(wx - wx[0], axis=1) >= ALIGN_M)
        k = int(np.argmax(far)) if far.any() else len(wt) - 1
        a, b = p[k] - p[0], wx[k] - wx[0]
        yaw = float(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b))
    c, s = np.cos(yaw), np.sin(yaw)
    aligned = (p - p[0]) @ np.array([[c, -s], [s, c]]).T + wx[0]
    return wt, aligned - wx


def sparse_marks(w: dict, calibration: Calibration, rotation: str = "start") -> dict:
    """``marks_of`` for a waypoint walk: squared Mahalanobis distances at the first waypoints at or
    after 30 s and 60 s and at the last one, the end error and the 95 % radius there."""
    wt, error = sparse_errors(w, rotation)
    t = w["t_s"]
    cov = covariance(w, calibration)
    idx = np.clip(np.searchsorted(t, wt), 0, len(t) - 1)
    out: dict = {}
    for mark in MARKS:
        if mark is not None and wt[-1] - t[0] < mark:
            continue
        j = len(wt) - 1 if mark is None else int(np.searchsorted(wt - t[0], mark))
        out[mark] = float(mahalanobis_sq(error[j : j + 1], cov[idx[j] : idx[j] + 1])[0])
    end = cov[idx[-1]]
    out["end_error"] = float(np.linalg.norm(error[-1]))
    out["r95"] = radius_holding(np.array([[end[0], end[1]], [end[1], end[2]]]), 0.95)
    return out


def walk_marks(w: dict, calibration: Calibration, rotation: str = "start") -> dict:
    return sparse_marks(w, calibration, rotation) if is_sparse(w) else marks_of(w, calibration)


def coherence_of(w: dict) -> float:
    t = w["t_s"]
    start = np.clip(np.searchsorted(t, w["span_t_s"][:, 0]), 0, len(t) - 1)
    end = np.clip(np.searchsorted(t, w["span_t_s"][:, 1]), 0, len(t) - 1)
    return direction_coherence(t, start, end, w["v_pred"])


def fit_scale_terms(fit: dict[str, list[dict]]) -> tuple[float, float]:
    """``(s0, g)`` of the fitting rule's step 1."""
    parts = [
        (np.array([path_ratio(w) - 1 for w in walks]), 1 - np.array([coherence_of(w) for w in walks]))
        for walks in fit.values()
    ]
    best, best_nll = (0.1, 0.0), np.inf
    for s0 in np.arange(0.02, 0.6, 0.01):
        for g in np.arange(0.0, 4.0, 0.05):
            nll = 0.0
            for e, lost in parts:
                var = s0**2 + (g * lost) ** 2
                nll += float(np.mean(np.log(var) + e**2 / var))
            if nll < best_nll:
                best, best_nll = (float(s0), float(g)), nll
    return best


def fit_heldout(groups: dict[str, list[dict]], base: Calibration, plain: bool = False) -> Calibration:
    """The fitting rule (module docstring) on the fit groups; the other constants stay ``base``'s.
    ``plain``: without the coherence term (``s0`` the group-weighted RMS of ratio - 1)."""
    fit = {g: groups[g] for g in FIT_GROUPS}
    if plain:
        mean_square = [np.mean([(path_ratio(w) - 1) ** 2 for w in walks]) for walks in fit.values()]
        scale, gain = float(np.sqrt(np.mean(mean_square))), 0.0
    else:
        scale, gain = fit_scale_terms(fit)
    n = sum(len(v) for v in fit.values())
    raw = replace(
        base, scale_sigma=scale, scale_sigma_by_carry={}, coherence_gain=gain, position_scale=1.0,
        position_scale_without_head=None,
        fitted_on=f"{n} walker-held-out walks the network never trained on (oxiod and ridi validation, "
        f"the new oxiod walkers of the variance head, ilc floors {'/'.join(FIT_FLOORS)} every "
        f"{EVERY}rd trace), phone only",
    )  # fmt: skip
    factor = weighted_factor(fit, raw)
    without = None if base.log_std_scale is None else weighted_factor(fit, raw.without_head())
    return replace(raw, position_scale=factor, position_scale_without_head=without)


def weighted_factor(groups: dict[str, list[dict]], calibration: Calibration) -> float:
    """The factor with which the 2-sigma ellipse at 30 s, 60 s and the end holds 86.5 % of the true
    positions, pooled with each group weighted alike (weighted quantile of the squared distances)."""
    values, weights = [], []
    for walks in groups.values():
        m2 = [v for w in walks for k, v in walk_marks(w, calibration).items() if k in MARKS]
        values += m2
        weights += [1.0 / len(m2)] * len(m2)
    order = np.argsort(values)
    cum = np.cumsum(np.array(weights)[order]) / np.sum(weights)
    return float(np.array(values)[order][np.searchsorted(cum, TWO_SIGMA)] / 4.0)


def coverage(walks: list[dict], calibration: Calibration, rotation: str = "start") -> tuple[int, float]:
    """``(walks whose true end lies within r95, Spearman(r95, end error))``."""
    marks = [walk_marks(w, calibration, rotation) for w in walks]
    r95 = np.array([m["r95"] for m in marks])
    err = np.array([m["end_error"] for m in marks])
    rho = spearmanr(r95, err).statistic if len(walks) > 2 else float("nan")
    return int(np.sum(err <= r95)), float(rho)


def in_target(walks: list[dict], calibration: Calibration) -> bool:
    """The adoption rule's count (step 3): the true end within r95 on 85-98 % of the group's walks."""
    return 0.85 <= coverage(walks, calibration)[0] / len(walks) <= 0.98


def row(name: str, walks: list[dict], calibrations: list[Calibration]) -> str:
    cells = []
    for cal in calibrations:
        inside, rho = coverage(walks, cal)
        r95 = np.median([walk_marks(w, cal)["r95"] for w in walks])
        se2 = f" ({coverage(walks, cal, 'se2')[0] / len(walks):.0%})" if is_sparse(walks[0]) else ""
        cells.append(f"{inside} of {len(walks)}: {inside / len(walks):.0%}{se2} | {rho:+.2f} | {r95:.1f}")
    ratio = np.median([path_ratio(w) for w in walks])
    coherence = np.median([coherence_of(w) for w in walks])
    err = np.median([walk_marks(w, calibrations[0])["end_error"] for w in walks])
    return f"| {name} | {len(walks)} | {ratio:.2f} | {coherence:.2f} | {err:.1f} | {' | '.join(cells)} |"


def table(
    groups: dict[str, list[dict]], names: tuple[str, ...], calibrations: list[Calibration]
) -> list[str]:
    labels = ("before", "plain refit", "adopted refit")[: len(calibrations)]
    pooled = [w for n in names for w in groups[n]]
    return [
        _head(labels),
        "|---|--:|--:|--:|--:|" + "--:|--:|--:|" * len(calibrations),
        *[row(n, groups[n], calibrations) for n in names],
        row("together", pooled, calibrations),
    ]


def _head(labels: tuple[str, ...]) -> str:
    cells = "".join(f"| {label}: end within r95 | Spearman | r95 median m " for label in labels)
    return f"| group | walks | path ratio median | coherence median | end error median m {cells}|"


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--save", action="store_true", help="write the refit to calibration.json if adopted")
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    model = load_model(CHECKPOINT)
    key = weights_key(model)
    walks = cached_walks(model, args.data_root, Path("runs/uncertainty_walks") / key)
    walks += cached_ilc_walks(
        model, args.data_root, Path("runs/uncertainty_ilc") / key, FIT_FLOORS + HELD_FLOORS, EVERY
    )
    groups = grouped(walks)
    before, plain, after, adopted = refits(groups, walks, calibration_for(CHECKPOINT.name))
    if args.save:  # the rule's choice: the validation fit stays where the refit brings no group in
        save_calibration(after if adopted else before)
    write_report(args.out, report(groups, [before, plain, after], adopted))


def grouped(walks: list[dict]) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = defaultdict(list)
    for w in walks:
        groups[group_of(w)].append(w)
    return groups


def refits(
    groups: dict[str, list[dict]], walks: list[dict], stored: Calibration
) -> tuple[Calibration, Calibration, Calibration, bool]:
    """``(before, plain refit, refit, adopted)`` by the rule (module docstring, step 3). "before" is the
    validation fit: what calibration.json held before this probe, remade from the validation probe's
    rule where calibration.json holds an entry fitted on ILC (a rerun after ``--save``)."""
    before = validation_fit(walks) if "ilc" in stored.fitted_on else stored
    plain, after = fit_heldout(groups, before, plain=True), fit_heldout(groups, before)
    adopted = sum(in_target(groups[g], after) for g in HELD_GROUPS) > sum(
        in_target(groups[g], before) for g in HELD_GROUPS
    )
    return before, plain, after, adopted


def validation_fit(walks: list[dict]) -> Calibration:
    from experiments.probe_uncertainty import fit  # noqa: PLC0415
    from experiments.uncertainty_walks import FIT_SETS  # noqa: PLC0415

    return fit([w for w in walks if str(w["dataset"]) in FIT_SETS], CHECKPOINT.name)


def report(groups: dict[str, list[dict]], calibrations: list[Calibration], adopted: bool) -> list[str]:
    before, plain, after = calibrations
    verdict = "adopted (`calibration.json`)" if adopted else "not adopted: no more held-out groups in target"
    return [
        "# The 95 % end radius on walkers, carries and places it was not fitted on",
        "",
        "Made by `python -m experiments.probe_uncertainty_heldout --save` (its docstring: question, groups,",
        f"the fitting rule, the ILC end error); `{CHECKPOINT.name}`, phone only.",
        "",
        f"- before: the validation fit (`experiments.probe_uncertainty`): speed scale "
        f"+-{before.scale_sigma:.2f} (per carry: "
        + ", ".join(f"{k} {v:.2f}" for k, v in sorted(before.scale_sigma_by_carry.items()))
        + f"), covariance x{before.position_scale:.2f};",
        f"- plain refit: speed scale +-{plain.scale_sigma:.2f} for every carry, covariance "
        f"x{plain.position_scale:.2f};",
        f"- adopted refit ({verdict}): speed scale +-{after.scale_sigma:.2f} "
        f"+ {after.coherence_gain:.2f} x (1 - coherence), in quadrature, "
        f"covariance x{after.position_scale:.2f} "
        f"(without the head's sigma x{after.position_scale_without_head or 0:.2f}).",
        "",
        "End within r95: walks whose true end lies within the 95 % radius (target 85-98 %; in brackets the",
        "ILC walks' share when the path is turned by the SE(2) fit over all waypoints instead of the start's",
        "direction); Spearman between radius and end error across the group's walks (target >= 0.5);",
        "coherence: the walks' direction coherence (1: the windows of a second agree).",
        "",
        "## Held out from every choice",
        "",
        *table(groups, HELD_GROUPS, calibrations),
        "",
        "## Fitted on",
        "",
        *table(groups, FIT_GROUPS, calibrations),
        "",
    ]


if __name__ == "__main__":
    main()
