"""``ftin.checkpoint``: save/load round trips, atomic writes, and clear errors for broken files."""

from __future__ import annotations

import json

import pytest
import torch

from ftin.checkpoint import CheckpointError, checkpoint_paths, checkpoint_tag, load_model, save_checkpoint
from ftin.data.windows import InputNormalization, Normalization
from ftin.models import create_model

TINY = {"channels": (8, 8), "kernel_size": 3}


def _save(tmp_path, dtype=torch.float32, name="tiny"):
    torch.manual_seed(0)
    model = create_model("ronin_tcn", **TINY)
    # Make batch-norm-free weights non-trivial and check that buffers survive too.
    norm = InputNormalization(Normalization.CHANNEL_STATS, (0, 0, 0.1, 0, 0, 9.8), (1, 1, 2, 3, 3, 1.5))
    meta = {
        "model_name": "ronin_tcn",
        "imu_rate_hz": 50.0,
        "window": 25,
        "stride": 5,
        "normalization": norm,
        "metrics": {"val_mse": float("nan"), "epoch": 3},
        "training_data": {"paths": ["/data/x"], "sequences": ["a", "b"]},
    }
    path = save_checkpoint(tmp_path / name, model, meta, dtype=dtype)
    return model.eval(), path, norm


def test_round_trip(tmp_path):
    model, path, norm = _save(tmp_path)
    assert path == tmp_path / "tiny.safetensors" and (tmp_path / "tiny.json").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]  # atomic writes leave nothing
    x = torch.randn(3, 6, 25)
    for given in (path, tmp_path / "tiny.json", tmp_path / "tiny", str(tmp_path / "tiny")):
        loaded = load_model(given)
        assert loaded.name == "tiny" and loaded.model_name == "ronin_tcn"
        assert (loaded.imu_rate_hz, loaded.window, loaded.stride, loaded.out_dim) == (50.0, 25, 5, 2)
        assert loaded.normalization == norm
        assert not loaded.model.training
        torch.testing.assert_close(loaded.model(x).velocity, model(x).velocity, rtol=0, atol=0)
    meta = json.loads((tmp_path / "tiny.json").read_text())
    assert meta["format_version"] == 1 and meta["model_kwargs"]["channels"] == [8, 8]
    assert meta["metrics"]["val_mse"] is None  # strict JSON: NaN becomes null
    assert meta["package_version"] and meta["weights_dtype"] == "float32"
    assert loaded.meta["training_data"]["sequences"] == ["a", "b"]


def test_float16_storage_is_upcast(tmp_path):
    model, path, _ = _save(tmp_path, torch.float16, "half")
    _, full, _ = _save(tmp_path, torch.float32, "full")
    assert path.stat().st_size < 0.7 * full.stat().st_size
    loaded = load_model(path)
    for key, value in loaded.model.state_dict().items():
        assert value.dtype == model.state_dict()[key].dtype
        torch.testing.assert_close(value, model.state_dict()[key], rtol=2e-3, atol=1e-4)


def test_checkpoint_paths():
    assert checkpoint_paths("a/b.c") == (
        checkpoint_paths("a/b.c.json")[0],
        checkpoint_paths("a/b.c.safetensors")[1],
    )  # a dotted stem keeps its dots


def test_missing_json(tmp_path):
    _, path, _ = _save(tmp_path)
    (tmp_path / "tiny.json").unlink()
    with pytest.raises(CheckpointError, match=r"missing its config tiny\.json"):
        load_model(path)


def test_missing_weights_and_nothing_there(tmp_path):
    _, path, _ = _save(tmp_path)
    path.unlink()
    with pytest.raises(CheckpointError, match="missing its weights file"):
        load_model(tmp_path / "tiny.json")
    with pytest.raises(CheckpointError, match="no checkpoint there"):
        load_model(tmp_path / "nothing")


def test_truncated_weights(tmp_path):
    _, path, _ = _save(tmp_path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 100])
    with pytest.raises(CheckpointError, match="truncated"):
        load_model(path)
    path.write_bytes(data[:5])
    with pytest.raises(CheckpointError, match="truncated"):
        load_model(path)


def test_corrupt_weights(tmp_path):
    _, path, _ = _save(tmp_path)
    data = bytearray(path.read_bytes())
    path.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00" + b"not json at all!" + bytes(data[24:]))
    with pytest.raises(CheckpointError, match="corrupt safetensors header"):
        load_model(path)
    data[-3] ^= 0xFF  # one flipped byte in the tensor data
    path.write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="do not match weights_sha256"):
        load_model(path)


def test_corrupt_json(tmp_path):
    _, path, _ = _save(tmp_path)
    (tmp_path / "tiny.json").write_text("{ not json")
    with pytest.raises(CheckpointError, match="not valid JSON"):
        load_model(path)
    (tmp_path / "tiny.json").write_text(json.dumps({"format_version": 99}))
    with pytest.raises(CheckpointError, match="newer"):
        load_model(path)


def _edit_meta(tmp_path, **changes):
    meta_path = tmp_path / "tiny.json"
    meta = json.loads(meta_path.read_text())
    meta.update(changes)
    meta_path.write_text(json.dumps(meta))


def test_mismatched_architecture(tmp_path):
    _, path, _ = _save(tmp_path)
    _edit_meta(tmp_path, model_kwargs={"channels": [8, 16], "kernel_size": 3})
    with pytest.raises(CheckpointError, match="do not match model 'ronin_tcn'.*shape mismatch"):
        load_model(path)
    _edit_meta(tmp_path, model_kwargs={"channels": [8, 8, 8], "kernel_size": 3})
    with pytest.raises(CheckpointError, match="missing: "):
        load_model(path)
    _edit_meta(tmp_path, model_kwargs={"channels": [8, 8], "kernel_size": 3, "bogus": 1})
    with pytest.raises(CheckpointError, match="rejects model_kwargs"):
        load_model(path)


def test_unknown_model_name(tmp_path):
    _, path, _ = _save(tmp_path)
    _edit_meta(tmp_path, model_name="no_such_net")
    with pytest.raises(CheckpointError, match="unknown model 'no_such_net'.*ronin_tcn"):
        load_model(path)


def test_save_requires_core_meta(tmp_path):
    model = create_model("ronin_tcn", **TINY)
    with pytest.raises(ValueError, match="imu_rate_hz"):
        save_checkpoint(tmp_path / "x", model, {"model_name": "ronin_tcn", "window": 25})


def test_a_checkpoint_says_which_weights_it_holds_not_its_file_name(tmp_path):
    """``tag`` in the JSON decides (a renamed file keeps it); a checkpoint from before the field falls
    back on its stem; a stem that does not start with the model's name gives no tag (shown as a file)."""
    _model, path, _norm = _save(tmp_path, name="renamed_by_hand")
    json_path = tmp_path / "renamed_by_hand.json"
    meta = json.loads(json_path.read_text())
    assert load_model(path).tag is None  # no field and a stem that names no model
    json_path.write_text(json.dumps({**meta, "tag": "oxiod"}))
    assert load_model(path).tag == "oxiod"
    _save(tmp_path, name="ronin_tcn-ridi")  # an old checkpoint: no field, the stem's words
    assert load_model(tmp_path / "ronin_tcn-ridi").tag == "ridi"
    for bad in ("", "OxIOD", 3, "a b"):
        json_path.write_text(json.dumps({**meta, "tag": bad}))
        with pytest.raises(CheckpointError, match="tag must say which weights of 'ronin_tcn'"):
            load_model(path)


def test_checkpoint_tag_fallback_does_not_split_a_longer_model_name():
    assert checkpoint_tag({"model_name": "rnin"}, "rnin-oxiod") == "oxiod"
    assert checkpoint_tag({"model_name": "ronin"}, "ronin_resnet-ridi") == "resnet-ridi"
    assert checkpoint_tag({"model_name": "rnin"}, "rninx-oxiod") is None
    assert checkpoint_tag({"model_name": "ftin"}, "ftin") == ""
    assert checkpoint_tag({"model_name": "ftin", "tag": "walking"}, "anything") == "walking"


def test_every_shipped_checkpoint_names_its_tag():
    """The shipped cards say which weights they hold; their file names agree (``<model>-<tag>``)."""
    from ftin.files import DEFAULT_CHECKPOINT_DIR

    cards = [p for p in sorted(DEFAULT_CHECKPOINT_DIR.glob("*.json")) if p.name != "default.json"]
    assert cards
    for card in cards:
        meta = json.loads(card.read_text())
        assert card.stem == f"{meta['model_name']}-{meta['tag']}", card.name
