"""The parts and streaming interfaces (ftin.models.base) of every model, and of the sequence baselines."""

from __future__ import annotations

import pytest
import torch

from ftin.models import VelocityModel, VelocityOutput, create_model, list_models

WINDOW = 200


def _window_for(model: VelocityModel) -> int:
    return int(model.config.get("window", WINDOW))


@pytest.mark.parametrize("name", list_models())
def test_forward_parts_shape_and_mean(name):
    model = create_model(name).eval()
    window = _window_for(model)
    parts = model.target_parts(window)
    x = torch.randn(2, 6, window, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        out, whole = model.forward_parts(x), model(x)
    assert out.velocity.shape == (2, parts, model.out_dim) and window % parts == 0
    if model.has_uncertainty:
        assert out.log_std.shape == (2, parts, model.out_dim)
    else:
        assert out.log_std is None
    # forward is the mean over the parts (equal durations): the window's velocity
    torch.testing.assert_close(whole.velocity, out.velocity.mean(dim=1), rtol=1e-5, atol=1e-6)
    assert model.streams == (name in ("ronin_lstm", "ronin_tcn"))


def test_parts_of_the_sequence_baselines():
    assert create_model("rnin", sub_window=100).target_parts(1000) == 10  # the reference's 10 x 1 s
    assert create_model("ronin_lstm").target_parts(400) == 400  # one per frame
    assert create_model("ronin_tcn").target_parts(400) == 400
    assert create_model("ronin_resnet").target_parts(200) == 1
    with pytest.raises(ValueError, match="multiple of sub_window"):
        create_model("rnin", sub_window=100).target_parts(150)
    assert create_model("rnin").train_loss == "rnin_displacement"
    assert create_model("ronin_lstm").train_loss == "ronin_position_full"
    assert create_model("ronin_tcn").train_loss == "ronin_position_part"
    assert create_model("tlio").train_loss == "velocity"


def test_window_models_do_not_stream():
    with pytest.raises(NotImplementedError, match="does not stream"):
        create_model("ronin_resnet").forward_stream(torch.zeros(1, 6, 200))


@pytest.mark.parametrize("name", ["ronin_lstm", "ronin_tcn"])
@pytest.mark.parametrize("chunk", [7, 100, 300])
def test_chunked_stream_equals_one_whole_sequence_pass(name, chunk):
    """Chunks through forward_stream (state carried) give the whole sequence's per-frame output, also
    with chunks far shorter than the TCN's 253-frame receptive field."""
    torch.manual_seed(0)
    model = create_model(name).eval()
    x = torch.randn(2, 6, 600)
    with torch.no_grad():
        whole = model.forward_parts(x).velocity  # (2, 600, 2): one pass from zero state
        single, _ = model.forward_stream(x)
        state, pieces = None, []
        for first in range(0, 600, chunk):
            velocity, state = model.forward_stream(x[:, :, first : first + chunk], state)
            pieces.append(velocity)
    torch.testing.assert_close(single, whole, rtol=0, atol=1e-6)
    torch.testing.assert_close(torch.cat(pieces, dim=1), whole, rtol=1e-4, atol=1e-5)
    if name == "ronin_tcn":
        assert state.shape == (2, 6, model.receptive_field - 1)  # the inputs the next chunk needs
    else:
        h, c = state
        assert h.shape == c.shape == (3, 2, 100)  # (layers, B, hidden)


def test_a_stream_window_is_a_training_chunk():
    """A window through forward_parts is a fresh stream: zero state, as the reference's training."""
    model = create_model("ronin_lstm", window=50).eval()
    x = torch.randn(1, 6, 50)
    with torch.no_grad():
        parts: VelocityOutput = model.forward_parts(x)
        stream, _ = model.forward_stream(x, None)
    torch.testing.assert_close(parts.velocity, stream)
