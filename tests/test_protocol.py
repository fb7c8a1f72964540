"""The evaluation protocol: disjoint splits by whole recording, carry modes in every part, walker folds
whose validation walkers never train, valid jobs, and the campaign's policy."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftin import protocol
from ftin.train.config import TrainConfig
from tests.utils.stage_one import STAGE_ONE, stage_one_comparisons

INRIA_CARRY = {"AR": "handheld", "Texting": "handheld", "Phoning": "handheld", "RunningHand": "handheld"}


@pytest.mark.parametrize("dataset", sorted(protocol.SPLITS))
def test_parts_are_disjoint_whole_recordings(dataset):
    parts = protocol.SPLITS[dataset]
    seen: set[str] = set()
    for name in ("train", "val", "test"):
        assert parts[name] and not seen & set(parts[name]), f"{dataset} {name} overlaps another part"
        seen |= set(parts[name])


def _carry(dataset: str, recording: str) -> str:
    if dataset == protocol.INRIA:
        motion = recording.rsplit("_", 1)[1]
        return INRIA_CARRY.get(motion, "swinging" if motion == "Swinging" else "pocket")
    if dataset == protocol.OXIOD:
        return "trolley" if recording.startswith("trolley") else "handheld"
    return next(mode for mode in ("bag", "body", "handheld", "leg") if mode in recording)


@pytest.mark.parametrize("dataset", sorted(protocol.SPLITS))
def test_every_carry_mode_in_every_part_where_the_data_allows(dataset):
    parts = protocol.SPLITS[dataset]
    modes = {name: {_carry(dataset, r) for r in parts[name]} for name in parts}
    for mode in set().union(*modes.values()):
        count = sum(_carry(dataset, r) == mode for part in parts.values() for r in part)
        in_parts = sum(mode in found for found in modes.values())
        assert in_parts == min(3, count), f"{dataset}: {mode} ({count} recordings) is in {in_parts} part(s)"


def test_ridi_test_users_appear_nowhere_else():
    parts = protocol.SPLITS[protocol.RIDI]
    users = {name: {r.split("_")[0] for r in parts[name]} for name in parts}
    assert {"huayi", "shali"} <= users["test"]
    assert not {"huayi", "shali"} & (users["train"] | users["val"])


def test_every_job_is_a_valid_training_config(tmp_path):
    jobs = protocol.campaign_jobs("ordered")
    names = [job.name for job in jobs]
    assert len(names) == len(set(names))
    for job in jobs:
        config = TrainConfig(out_dir=str(tmp_path / job.name), **job.config(Path("/data")))
        assert config.early_stop_patience == protocol.COMMON["early_stop_patience"]
        assert config.window is not None and config.stride * protocol.PASSES_PER_EPOCH == config.window
    seeds = {(j.model, j.dataset): set() for j in jobs}
    for job in jobs:
        seeds[(job.model, job.dataset)].add(job.seed)
    for model in protocol.MULTI_SEED:
        for dataset in (protocol.OXIOD, protocol.RIDI):
            assert seeds[(model, dataset)] >= set(protocol.SEEDS), (model, dataset)
    # before the variant is chosen only seed 0 of both FTIN variants runs
    early = protocol.campaign_jobs(None)
    assert {j.variant for j in early if j.model == "ftin"} == {"mixed", "ordered"}
    assert all(j.seed == 0 for j in early if j.model == "ftin")


def test_split_paths_exist_in_the_shared_data(shared_data):
    for dataset in protocol.SPLITS:
        for part in ("train", "val", "test"):
            for path in protocol.split_paths(shared_data, dataset, part):
                assert path.exists(), path


def test_test_parts_are_the_first_campaigns_and_inrias_is_the_iphone_4s():
    assert protocol.SPLITS[protocol.OXIOD]["test"] == (
        "multi users/user2/syn/imu6.csv",
        "trolley/data2/syn/imu5.csv",
    )
    assert protocol.SPLITS[protocol.RIDI]["test"] == (
        "huayi_bag2",
        "huayi_body_test1",
        "shali_handheld1",
        "hao_leg2",
    )
    inria = protocol.SPLITS[protocol.INRIA]
    assert len(inria["test"]) == 28 and all("_iPhone4S_" in r for r in inria["test"])
    assert not any("_iPhone4S_" in r for r in (*inria["train"], *inria["val"]))
    assert len(inria["train"]) + len(inria["val"]) == 56


@pytest.mark.parametrize("dataset", sorted(protocol.WALKER_FOLDS))
def test_walker_folds_never_validate_on_a_training_walker(dataset):
    pool = None
    validated: list[str] = []
    for fold in protocol.FOLDS:
        parts = protocol.fold_parts(dataset, fold)
        train = {protocol.walker(dataset, r) for r in parts["train"]}
        val = {protocol.walker(dataset, r) for r in parts["val"]}
        assert train and val and not train & val, (fold, train, val)
        assert parts["test"] == protocol.SPLITS[dataset]["test"]  # the test part is untouched
        assert not set(parts["test"]) & (set(parts["train"]) | set(parts["val"]))
        everything = set(parts["train"]) | set(parts["val"])
        assert pool is None or everything == pool  # every fold splits the same recordings
        pool = everything
        validated += sorted(val)
    assert sorted(validated) == sorted({protocol.walker(dataset, r) for r in pool})  # each walker once


def test_walkers_are_named_by_folder_and_first_word():
    assert protocol.walker(protocol.OXIOD, "handheld/data1/syn/imu2.csv") == "user1"
    assert protocol.walker(protocol.OXIOD, "multi users/user2/syn/imu4.csv") == "user2"
    assert protocol.walker(protocol.OXIOD, "trolley/data2/syn/imu1.csv") == "trolley-data2"
    assert protocol.walker(protocol.RIDI, "hang_body_fast1") == "hang"
    assert protocol.walker(protocol.INRIA, "ios/Thibaud_iPhone5_NoDist_AR") == "Thibaud"


def test_the_walking_dataset_joins_every_walking_dataset(tmp_path):
    for part in ("train", "val", "test"):
        for fold in (None, *protocol.FOLDS):
            joined = protocol.split_paths(tmp_path, protocol.WALKING, part, fold)
            members = [
                protocol.split_paths(tmp_path, d, part, fold) for d in protocol.COMBINED[protocol.WALKING]
            ]
            assert joined == [p for paths in members for p in paths]
    assert protocol.split_paths(tmp_path, protocol.INRIA, "test")[0].parent.parent == (
        tmp_path / "inria_attitude" / "datasets"
    )
    with pytest.raises(ValueError, match="no walker fold 2"):
        protocol.fold_parts(protocol.RIDI, 2)


@pytest.mark.parametrize(
    ("model", "dataset", "expected"),
    [
        ("ftin", "ridi", {"imu_rate_hz": 200.0, "window": 200, "stride": 40}),
        ("ronin_resnet", "oxiod", {"imu_rate_hz": 100.0, "window": 100, "stride": 20}),
        (
            "rnin",
            "oxiod",
            {"imu_rate_hz": 100.0, "window": 1000, "stride": 200, "batch_size": 32, "loss": "mse",
             "model_kwargs": {"sub_window": 100}},
        ),
        (
            "rnin",
            "ridi",
            {"imu_rate_hz": 200.0, "window": 2000, "stride": 400, "batch_size": 32, "loss": "mse",
             "model_kwargs": {"sub_window": 200}},
        ),
        ("ronin_lstm", "ridi", {"imu_rate_hz": 200.0, "window": 400, "stride": 80, "batch_size": 72}),
        ("ronin_tcn", "walking", {"imu_rate_hz": 100.0, "window": 400, "stride": 80, "batch_size": 72}),
        ("tlio", "oxiod", {"imu_rate_hz": 100.0, "window": 100, "stride": 20, "nll_warmup_epochs": 5}),
    ],
)  # fmt: skip
def test_model_options_are_the_protocols_defaults_under_the_models_own_recipe(model, dataset, expected):
    """1 s windows, five passes per epoch, unless the registry entry's ``train_options`` say otherwise
    (RNIN's ten sub-windows, RoNIN LSTM/TCN's 400-frame chunks, TLIO's NLL warm-up)."""
    options = protocol.model_options(model, dataset)
    assert options == expected
    assert list(options)[:3] == ["imu_rate_hz", "window", "stride"]  # job files keep their key order


def test_a_job_is_data_and_a_variant_only_changes_its_options(tmp_path):
    job = protocol.Job.from_json(
        {"name": "f0/ridi/ftin-paper-s0", "model": "ftin", "dataset": "ridi", "seed": 0, "fold": 0,
         "variant": "paper", "options": protocol.RECIPES["paper"]}
    )  # fmt: skip
    assert protocol.Job.from_json(job.to_json()) == job
    config = TrainConfig(out_dir=str(tmp_path), **job.config(tmp_path))
    assert (config.lr, config.batch_size, config.max_epochs) == (1e-4, 512, 100)
    assert config.window == 200 and config.stride == 40  # the model's options at RIDI's rate stay
    walkers = {protocol.walker(protocol.RIDI, Path(p).name) for p in config.val}
    assert walkers == {"dan"}
    with pytest.raises(ValueError, match="unknown key"):
        protocol.Job.from_json({"name": "x", "model": "ftin", "dataset": "ridi", "epochs": 3})


def test_the_variant_is_chosen_on_both_datasets_validation_only():
    assert protocol.choose_variant({"mixed": {"oxiod": 1.0, "ridi": 1.0}}) == (None, {})
    chosen, scores = protocol.choose_variant(
        {"mixed": {"oxiod": 0.004, "ridi": 0.04}, "ordered": {"oxiod": 0.005, "ridi": 0.02}}
    )
    assert chosen == "ordered" and scores["mixed"] == pytest.approx(0.004**0.5 * 0.04**0.5)
    assert protocol.sim_job(chosen).options["model_kwargs"] == {"fdl_output": "ordered"}
    assert [j.name for j in protocol.campaign_jobs(chosen)].count("sim/ftin-ordered-s0") == 1


def _record(ratio: float, ate: float, still: float) -> dict:
    row = {"path_length_ratio": ratio, "ate": ate, "stand_still": {"ate": still}}
    return {
        "evaluation": {
            "parts": {"ridi/val/ground_truth": [row], "ridi/test/ground_truth": [row | {"ate": 0}]}
        }
    }


def test_the_gate_refuses_what_has_not_learned_to_walk():
    assert protocol.validation_gate(_record(1.0, 1.0, 2.0))["refused"] is None
    assert "path ratio" in protocol.validation_gate(_record(0.7, 1.0, 2.0))["refused"]
    assert "standing still" in protocol.validation_gate(_record(1.0, 2.5, 2.0))["refused"]


def test_the_gate_weighs_each_validation_dataset_alike():
    def rows(ratio: float, ate: float, still: float, n: int) -> list[dict]:
        return [{"path_length_ratio": ratio, "ate": ate, "stand_still": {"ate": still}}] * n

    parts = {
        "oxiod/val/ground_truth": rows(0.95, 0.5, 2.5, 2),
        "ridi/val/ground_truth": rows(0.95, 1.0, 12.0, 4),
        "inria/val/ground_truth": rows(0.70, 1.1, 1.4, 28),  # many short walks in a small room
        "inria/val/phone_only": rows(0.1, 9.0, 1.4, 28),  # other orientations do not count
        "inria/test/ground_truth": rows(0.1, 9.0, 1.4, 28),  # nor the test part
    }
    gate = protocol.validation_gate({"evaluation": {"parts": parts}})
    assert gate["refused"] is None
    assert gate["val_path_length_ratio"] == pytest.approx((0.95 + 0.95 + 0.70) / 3)
    assert gate["val_path_length_ratio_pooled"] == pytest.approx((6 * 0.95 + 28 * 0.70) / 34)
    assert gate["val_path_length_ratio_per_dataset"]["inria"] == pytest.approx(0.70)
    parts["inria/val/ground_truth"] = rows(0.70, 1.6, 1.4, 28)  # Inria above its standing still
    parts["oxiod/val/ground_truth"] = rows(0.95, 2.4, 2.5, 2)
    parts["ridi/val/ground_truth"] = rows(0.95, 11.0, 12.0, 4)
    assert "standing still" in protocol.validation_gate({"evaluation": {"parts": parts}})["refused"]


def test_the_generalisation_campaign_decides_on_walkers_it_never_trained_on():
    jobs = protocol.generalisation_jobs()
    names = [job.name for job in jobs]
    assert len(set(names)) == len(jobs) == 9 * 2 * 2 + 2 * 2  # 9 arms x 2 seeds x 2 folds; paper: 1 seed
    # each question's pair of arms on both folds before the next one; the 100-epoch paper recipe last
    assert names[:4] == [
        "walking-f0/ftin-ordered-yaw-s0",
        "walking-f0/ronin_resnet-yaw-s0",
        "walking-f1/ftin-ordered-yaw-s0",
        "walking-f1/ronin_resnet-yaw-s0",
    ]
    assert all(job.options.get("lr") == 1e-4 for job in jobs[-4:])
    assert all(job.seed == 0 for job in jobs[:18]) and all(job.seed == 1 for job in jobs[18:36])
    assert jobs[8].options["augment"] == {"mirror": None}
    assert all(job.fold in protocol.FOLDS for job in jobs)
    for job in jobs:
        train = {(d, protocol.walker(d, rel)) for d, rel in _members(job, "train")}
        val = {(d, protocol.walker(d, rel)) for d, rel in _members(job, "val")}
        assert train and val and not train & val, job.name
    arms = {job.name.split("/")[1].rsplit("-s", 1)[0] for job in jobs}
    assert {
        "ftin-ordered-aug",
        "ronin_resnet-paper",
        "ftin-mixed-yaw",
        "ronin_resnet-mirror",
        "ftin-ordered-pace",
    } <= arms
    assert jobs[12].options["augment"] == {"pace": None}


def test_the_tilt_question_differs_from_stage_ones_resnet_mirror_runs_by_tilt_alone():
    """So that the paired comparison asks about the tilt errors and nothing else."""
    mirror = {job.name: job for job in protocol.generalisation_jobs() if "ronin_resnet-mirror-" in job.name}
    tilt = protocol.tilt_question_jobs()
    assert len(tilt) == len(mirror) == 4
    for job in tilt:
        twin = mirror[job.name.replace("mirror-tilt", "mirror")]
        assert (job.model, job.dataset, job.seed, job.fold) == (
            twin.model,
            twin.dataset,
            twin.seed,
            twin.fold,
        )
        assert job.options == {**twin.options, "augment": {"mirror": None, "tilt": None}}
        assert protocol.arm_of(job.name) == "ronin_resnet-mirror-tilt"
    assert "tilt" in protocol.CAMPAIGNS


def _members(job, part):
    for dataset in protocol.COMBINED[job.dataset]:
        for path in job.paths(Path("/data"), part, dataset):
            yield dataset, path.relative_to(Path("/data") / protocol.DATA_FOLDERS[dataset]).as_posix()


def test_stage_two_takes_stage_one_choices_from_the_phone_only_rows_over_every_dataset():
    choices = protocol.stage_two_choices(stage_one_comparisons(STAGE_ONE))
    assert choices.ftin_variant == "mixed" and choices.recipe == "ours"
    assert choices.augment["ftin"] == {**protocol.GENERALISATION_AUGMENT, "mirror": None}
    assert choices.augment["ronin_resnet"] == {"mirror": None, "pace": None}
    assert "mean d -0.200 m" in choices.why["ftin_variant"] and "ours" in choices.why["recipe"]
    missing = {k: v for k, v in STAGE_ONE.items() if k != ("ronin_resnet-paper", "ronin_resnet-yaw")}
    with pytest.raises(ValueError, match="not compared ronin_resnet-paper with ronin_resnet-yaw"):
        protocol.stage_two_choices(stage_one_comparisons(missing))


def test_stage_two_retrains_every_checkpoint_with_the_choices_default_candidates_first():
    choices = protocol.StageTwoChoices("mixed", "paper", {"ftin": {"mirror": None}, "ronin_resnet": {}}, {})
    jobs = protocol.stage_two_jobs(choices)
    names = [job.name for job in jobs]
    assert len(set(names)) == len(names)
    assert names[:2] == ["walking/ftin-mixed-s0", "walking/ronin_resnet-s0"]  # the default's candidates
    assert {job.checkpoint_stem for job in jobs[:2]} == {"ftin-walking", "ronin_resnet-walking"}
    for model, seeds in (
        ("ftin-mixed", 5),
        ("resnet_tdl", 5),
        ("ronin_resnet", 5),
        ("resnet_fdl", 3),
        ("tlio", 1),
    ):
        for dataset in ("oxiod", "ridi"):
            assert sum(n.startswith(f"{dataset}/{model}-s") for n in names) == seeds, (model, dataset)
    by_name = {job.name: job for job in jobs}
    assert by_name["oxiod/resnet_tdl-s4"].options["augment"] == {"mirror": None}  # FTIN's family
    assert "augment" not in by_name["ridi/rnin-s0"].options  # ResNet's choice: yaw only
    assert all(job.options["lr"] == 1e-4 and job.options["batch_size"] == 512 for job in jobs)
    assert by_name["oxiod/ftin-mixed-s3"].options["model_kwargs"]["fdl_output"] == "mixed"
    assert names[-1] == "sim/ftin-mixed-s0" and jobs[-1].options["augment"] == {"mirror": None}


def test_oxiod_walkers_of_the_new_folders_are_told_apart() -> None:
    assert protocol.walker(protocol.OXIOD, "multi users/user2/syn/imu4.csv") == "user2"
    assert protocol.walker(protocol.OXIOD, "multi users/user3/syn/imu7.csv.xz") == "user3"
    assert protocol.walker(protocol.OXIOD, "multi users/user4/syn/imu4.csv.xz") == "user4"
    assert protocol.walker(protocol.OXIOD, "handheld/data1/syn/imu2.csv") == "user1"
    assert protocol.walker(protocol.OXIOD, "large scale/floor1/syn/imu3.csv.xz") == "large scale-floor1"


def test_the_retrain_arms_differ_from_the_defaults_recipe_by_the_bounce_alone(shared_data, tmp_path):
    """Stage three's retrain: the shipped default's recipe on the pooled walkers, and the same with the
    bounce scaled; no floor walk or validation walker in training."""
    import json

    from ftin.protocol.stage_three import FLOOR_DRIFT, NEW_VAL, REFERENCE_DISAGREES, stage_three_retrain_jobs

    card = Path(__file__).resolve().parents[1] / "checkpoints" / "ronin_resnet-walking.json"
    shipped = json.loads(card.read_text())["train_config"]
    pooled, damped, agreeing = stage_three_retrain_jobs(shared_data)
    for job in (pooled, damped, agreeing):
        config = TrainConfig(out_dir=str(tmp_path / job.name), **job.config(shared_data))
        for key in ("model", "window", "stride", "batch_size", "lr", "max_epochs", "orientation"):
            assert getattr(config, key) == shipped[key], key
        train = set(job.parts["train"])
        assert not train & set(job.parts["val"]) and not train & set(FLOOR_DRIFT)
        assert set(NEW_VAL) - set(REFERENCE_DISAGREES) <= set(job.parts["val"])
        assert all((shared_data / rel).exists() for part in job.parts.values() for rel in part)
    assert pooled.options["augment"] == shipped["augment"]
    assert damped.options == {**pooled.options, "augment": {**shipped["augment"], "vertical": 0.6}}
    assert damped.parts == pooled.parts and agreeing.options == pooled.options
    for part in ("train", "val"):
        kept = set(agreeing.parts[part])
        assert kept == set(pooled.parts[part]) - set(REFERENCE_DISAGREES)
    assert len(agreeing.parts["train"]) == len(pooled.parts["train"]) - len(REFERENCE_DISAGREES)
    assert "stage-three-retrain" in protocol.CAMPAIGNS


def test_a_combined_jobs_own_parts_are_scored_per_member_dataset_on_its_walks_alone():
    """A walking job with explicit parts: each member dataset's evaluation reads its own walks, not the
    whole part under every member's name (the gate weighs the datasets alike), with the reference."""
    parts = {
        "train": ("ridi/a",),
        "val": ("oxiod/handheld/data1/syn/imu3.csv", "ridi/b", "inria_attitude/datasets/ios/W_iPhone5_AR"),
        "test": ("oxiod/large scale/floor1/syn/imu1.csv.xz",),
    }
    job = protocol.Job("j", "ronin_resnet", protocol.WALKING, 0, None, {}, None, parts)
    root = Path("/data")
    val = {d: job.paths(root, "val", d) for d in (protocol.OXIOD, protocol.RIDI, protocol.INRIA)}
    assert val == {
        protocol.OXIOD: [root / parts["val"][0]],
        protocol.RIDI: [root / "ridi/b"],
        protocol.INRIA: [root / parts["val"][2]],
    }
    assert job.paths(root, "val") == [root / rel for rel in parts["val"]]  # training reads them all
    assert job.paths(root, "test", protocol.RIDI) == []
    # scored on the reference orientation, as the gate reads it (Inria's reader defaults to the phone's)
    assert {orientations for _, _, orientations in job.evaluation_sets()} == {("ground_truth",)}
