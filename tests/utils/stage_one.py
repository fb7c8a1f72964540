"""Stage one's paired comparisons as ``ftin campaign crossval`` writes them, for stage two's tests."""

from __future__ import annotations


def _comparison(a, b, mean_m, pairs=40, orientation="phone_only", dataset="all"):
    lower = "a" if mean_m < 0 else "b"
    return {
        "a": a,
        "b": b,
        "orientation": orientation,
        "dataset": dataset,
        "mean_m": mean_m,
        "pairs": pairs,
        "walkers": 10,
        "lower_mean": lower,
    }


def stage_one_comparisons(means):
    """Phone-only rows over every dataset, plus ground-truth and one-dataset rows that say the opposite
    (a choice must ignore them)."""
    rows = []
    for (a, b), mean_m in means.items():
        rows.append(_comparison(a, b, mean_m))
        rows.append(_comparison(a, b, -mean_m, orientation="ground_truth"))
        rows.append(_comparison(a, b, -mean_m, dataset="inria"))
    return rows


STAGE_ONE = {
    ("ftin-mixed-yaw", "ftin-ordered-yaw"): -0.2,  # mixed lower
    ("ftin-ordered-aug", "ftin-ordered-yaw"): -1.5,  # FTIN: aug yes
    ("ftin-ordered-mirror", "ftin-ordered-yaw"): -0.3,  # FTIN: mirror yes
    ("ronin_resnet-aug", "ronin_resnet-yaw"): +0.4,  # ResNet: aug no
    ("ronin_resnet-mirror", "ronin_resnet-yaw"): -0.1,  # ResNet: mirror yes
    ("ftin-ordered-pace", "ftin-ordered-yaw"): +0.2,  # FTIN: pace no
    ("ronin_resnet-pace", "ronin_resnet-yaw"): -0.2,  # ResNet: pace yes
    ("ftin-ordered-paper", "ftin-ordered-yaw"): -0.5,  # pooled: -0.5 * 40 + 0.8 * 40 > 0: ours
    ("ronin_resnet-paper", "ronin_resnet-yaw"): +0.8,
}
