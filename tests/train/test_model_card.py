"""Model cards of campaign checkpoints: curve, learning-rate decays, stand-still, path ratio, seeds."""

from __future__ import annotations

from ftin.train.model_card import render_campaign_card


def _record(seed, val_mse, ate):
    rows = [
        {
            "name": "walk",
            "ate": ate,
            "rte": 1.0,
            "pde": 0.02,
            "path_length_ratio": 0.97,
            "stand_still": {"ate": 2.5, "rte": 2.0, "pde": 0.9},
        }
    ]
    return {
        "training": {
            "job": f"oxiod/ftin-s{seed}",
            "model": "ftin",
            "dataset": "oxiod",
            "seed": seed,
            "stop_reason": "early_stop",
            "epochs": 3,
            "wall_time_s": 600.0,
            "best_epoch": 1,
            "lr_decays": 1,
            "best_val_mse": val_mse,
        },
        "history": [
            {"epoch": e, "val_mse": v, "lr": lr}
            for e, v, lr in ((1, val_mse, 1e-3), (2, 0.2, 1e-3), (3, 0.3, 3e-4))
        ],
        "evaluation": {"parts": {"oxiod/test/ground_truth": rows, "oxiod/val/device": rows}},
    }


META = {
    "model_name": "ftin",
    "model_kwargs": {"fdl_output": "ordered"},
    "window": 100,
    "imu_rate_hz": 100.0,
    "stride": 20,
    "out_dim": 2,
    "train_config": {"name": "ftin-oxiod", "orientation": "ground_truth", "early_stop_patience": 8},
    "split": {"train": ["a", "b"], "val": ["c"]},
}


def test_campaign_card_states_what_a_reader_needs():
    shipped = _record(0, 0.01, 0.8)
    card = render_campaign_card(META, shipped, [shipped, _record(1, 0.02, 0.9)], "ordered")
    assert card.startswith("# ftin-oxiod\n")
    assert "TDL variant `ordered`, chosen on validation" in card and "OxIOD" in card
    assert "learning rate decayed 1 time(s) (the curve flattened)" in card
    assert "| val MSE | 0.0100 | 0.2000 | 0.3000 |" in card
    assert "## oxiod test, ground-truth orientation" in card and "## oxiod val, device orientation" in card
    assert card.index("oxiod test") < card.index("oxiod val")  # test first
    # a campaign that names its FTIN arm otherwise (the stride control's "pooled") chose no TDL variant
    other = render_campaign_card(META, shipped, [shipped], "pooled")
    assert "(TDL variant `ordered`)" in other and "pooled" not in other
    # every registered table metric (PDE in %; a metric the record predates shows —), stand-still ATE last
    header = "| recording | ATE [m] | ATE evo [m] | RTE [m] | PDE [%] | Path ratio | stand-still ATE [m] |"
    assert header in card
    assert "| walk | 0.800 | — | 1.000 | 2.00 | 0.97 | 2.500 |" in card
    assert "| 1 | 0.02000 | 0.900 | 0.97 |" in card  # the other seed


def test_card_says_when_the_curve_may_not_have_flattened():
    record = _record(0, 0.01, 0.8)
    record["training"]["lr_decays"] = 0
    assert "no decay: the curve may not have flattened" in render_campaign_card(META, record, [record])


def test_campaign_card_names_augmentations_beyond_yaw():
    shipped = _record(0, 0.01, 0.8)
    plain = render_campaign_card(META, shipped, [shipped], "ordered")
    assert "yaw augmentation, loss" in plain
    config = {**META["train_config"], "augment": {"vertical": None, "tilt": 2.0}}
    card = render_campaign_card({**META, "train_config": config}, shipped, [shipped], "ordered")
    assert "yaw augmentation + vertical 0.3 + tilt 2, loss" in card
