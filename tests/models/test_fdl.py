"""Frequency-domain learning: spectra land in the right bins, the FFT path is exact, the product complex."""

from __future__ import annotations

import math

import pytest
import torch

from ftin.models.layers.fdl import (
    Activation,
    ComplexLinear,
    FDLOutput,
    FrequencyDomainLearning,
    apply_activation,
)


def _set_identity(fdl: FrequencyDomainLearning) -> None:
    with torch.no_grad():
        for layer in [*fdl.channel_mlp.layers, *fdl.temporal_mlp.layers]:
            layer.weight_real.copy_(torch.eye(layer.dim))
            layer.weight_imag.zero_()
            layer.bias_real.zero_()
            layer.bias_imag.zero_()


def test_pure_tone_along_time_lands_in_its_rfft_bin() -> None:
    torch.manual_seed(0)
    channels, length, dim, tone_bin = 6, 7, 4, 2
    fdl = FrequencyDomainLearning(channels, length, dim, activation="identity")
    _set_identity(fdl)  # the channel learner passes the tone through unchanged
    amplitude = torch.rand(2, channels, 1) + 0.5  # (B, C, 1), a different amplitude per channel
    t = torch.arange(length, dtype=torch.float32)
    x = amplitude * torch.cos(2 * math.pi * tone_bin * t / length)  # (B, C, L)
    features: dict = {}
    fdl(x, features)

    spectrum = features["fdl_temporal_spectrum"]  # (B, C, L // 2 + 1, d)
    assert spectrum.shape == (2, channels, length // 2 + 1, dim)
    assert (spectrum.argmax(dim=2) == tone_bin).all()
    # Ortho rfft of A cos(2 pi k n / L), 0 < k < L/2, has |X_k| = A sqrt(L) / 2 and nothing elsewhere.
    expected = (amplitude[..., None] * fdl.embedding[0].abs()) * math.sqrt(length) / 2  # (B, C, 1, d)
    torch.testing.assert_close(
        spectrum[:, :, tone_bin : tone_bin + 1], expected.detach(), atol=1e-5, rtol=1e-5
    )
    others = torch.cat([spectrum[:, :, :tone_bin], spectrum[:, :, tone_bin + 1 :]], dim=2)
    assert others.max() < 1e-5


@pytest.mark.parametrize(("channels", "length"), [(8, 4), (9, 7), (128, 7)])
def test_identity_weights_make_the_fft_path_return_its_input(channels: int, length: int) -> None:
    torch.manual_seed(1)
    fdl = FrequencyDomainLearning(channels, length, embed_dim=3, n_layers=2, activation="identity")
    _set_identity(fdl)
    x = torch.randn(2, channels, length)
    tokens = fdl.embed(x)  # (B, d, L, C)
    torch.testing.assert_close(fdl.learn_channels(tokens), tokens, atol=1e-5, rtol=1e-5)
    by_time = tokens.transpose(2, 3)  # (B, d, C, L)
    torch.testing.assert_close(fdl.learn_time(by_time), by_time, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("residual", [False, True])
def test_forward_with_identity_mixing_is_embedding_then_fc(residual: bool) -> None:
    """Pins the whole FDL: embedding x * W1, the (L_res x d) flatten order, both FCs, the residual."""
    torch.manual_seed(2)
    channels, length, dim = 10, 5, 3
    fdl = FrequencyDomainLearning(
        channels, length, dim, out_channels=4, out_length=6, activation="identity", residual=residual
    )
    _set_identity(fdl)
    x = torch.randn(3, channels, length)
    tokens = x[..., None] * fdl.embedding[0]  # (B, C, L, d), the paper's layout
    mixed = 2 * tokens if residual else tokens
    expected = fdl.fc_channel(fdl.fc_time(mixed.reshape(3, channels, length * dim)).transpose(1, 2))
    torch.testing.assert_close(fdl(x), expected.transpose(1, 2), atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("activation", [Activation.IDENTITY, Activation.RELU])
def test_complex_layer_is_the_full_complex_matrix_product(activation: Activation) -> None:
    torch.manual_seed(3)
    dim = 5
    layer = ComplexLinear(dim, activation).double()
    with torch.no_grad():
        layer.bias_real.normal_()
        layer.bias_imag.normal_()
    y = torch.randn(2, dim, 3, 4, dtype=torch.complex128)  # (B, d, ...)
    out = layer(y)

    w = torch.complex(layer.weight_real, layer.weight_imag).detach()
    b = torch.complex(layer.bias_real, layer.bias_imag).detach()
    rows = y.movedim(1, -1)  # (B, ..., d): row vectors, as in the paper's y W + B
    linear = rows @ w + b  # torch's complex matmul
    if activation is Activation.IDENTITY:
        torch.testing.assert_close(out.movedim(1, -1), linear)
    # The paper's equation written out with real matrices, activation on real and imaginary parts.
    wr, wi = layer.weight_real.detach(), layer.weight_imag.detach()
    re = rows.real @ wr - rows.imag @ wi + layer.bias_real.detach()
    im = rows.real @ wi + rows.imag @ wr + layer.bias_imag.detach()
    if activation is Activation.RELU:
        re, im = re.relu(), im.relu()
    torch.testing.assert_close(out.movedim(1, -1), torch.complex(re, im))
    # Not FreTS's diagonal-only product: off-diagonal weights matter.
    with torch.no_grad():
        layer.weight_real.fill_diagonal_(0.0)
        layer.weight_imag.fill_diagonal_(0.0)
    assert layer(y).abs().sum() > 0


def test_odd_res_length_trains_both_learners() -> None:
    torch.manual_seed(4)
    fdl = FrequencyDomainLearning(in_channels=9, in_length=7, embed_dim=4, out_channels=5, out_length=3)
    x = torch.randn(2, 9, 7)
    out = fdl(x)
    assert out.shape == (2, 5, 3)
    assert torch.isfinite(out).all()
    out.square().sum().backward()
    for name in ["channel_mlp", "temporal_mlp"]:  # FreTS never ran its channel learner: ours must train
        grads = [p.grad for p in getattr(fdl, name).parameters()]
        assert all(g is not None and torch.isfinite(g).all() for g in grads)
        assert sum(g.abs().sum() for g in grads) > 0


def test_taps_only_when_asked_and_detached() -> None:
    fdl = FrequencyDomainLearning(in_channels=8, in_length=4, embed_dim=2)
    x = torch.randn(3, 8, 4)
    features: dict = {}
    with_taps = fdl(x, features)
    assert set(features) == {"fdl_channel_spectrum", "fdl_temporal_spectrum"}
    assert features["fdl_channel_spectrum"].shape == (3, 8 // 2 + 1, 4, 2)
    assert features["fdl_temporal_spectrum"].shape == (3, 8, 4 // 2 + 1, 2)
    assert not any(t.requires_grad for t in features.values())
    torch.testing.assert_close(fdl(x), with_taps)


def test_wrong_input_shape_names_what_was_expected() -> None:
    fdl = FrequencyDomainLearning(in_channels=8, in_length=4)
    with pytest.raises(ValueError, match=r"\(B, 8, 4\).*another window length"):
        fdl(torch.randn(2, 8, 7))
    with pytest.raises(ValueError, match="activation must be one of"):
        FrequencyDomainLearning(in_channels=8, in_length=4, activation="tanh")


@pytest.mark.parametrize("output", ["mixed", "ordered"])
def test_gradients_match_finite_differences(output: str) -> None:
    """The in-place ReLU and residual must not corrupt autograd: gradcheck inputs and weights."""
    torch.manual_seed(5)
    fdl = FrequencyDomainLearning(
        in_channels=5, in_length=3, embed_dim=2, out_channels=2, out_length=2, output=output
    ).double()
    with torch.no_grad():
        for layer in [*fdl.channel_mlp.layers, *fdl.temporal_mlp.layers]:
            layer.bias_real.normal_()
            layer.bias_imag.normal_()
    names = [name for name, _ in fdl.named_parameters()]
    x = torch.randn(2, 5, 3, dtype=torch.float64, requires_grad=True)
    params = tuple(p.detach().clone().requires_grad_(True) for p in fdl.parameters())

    def run(x: torch.Tensor, *weights: torch.Tensor) -> torch.Tensor:
        return torch.func.functional_call(fdl, dict(zip(names, weights, strict=True)), (x,))

    assert torch.autograd.gradcheck(run, (x, *params), fast_mode=True)


# ------------------------------------------------------------------ step 5, the output FC: two modes
def _paper_tokens(batch: int, channels: int, length: int, dim: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Random residual sums in the paper's ``(B, C, L, d)`` order and in ``project``'s ``(B, d, C, L)``."""
    paper = torch.randn(batch, channels, length, dim, dtype=torch.float64)
    return paper, paper.permute(0, 3, 1, 2)


@pytest.mark.parametrize("activation", ["identity", "relu", "gelu"])
def test_mixed_fc_pair_is_one_fc_with_a_kronecker_weight(activation: str) -> None:
    """``fc_time`` then ``fc_channel`` then one activation == sigma(kron(G, A) vec(X) + b), dense."""
    torch.manual_seed(6)
    channels, length, dim, out_channels, out_length = 6, 5, 3, 4, 7
    fdl = FrequencyDomainLearning(
        channels, length, dim, out_channels, out_length, activation=activation, output="mixed"
    ).double()
    paper, mixed = _paper_tokens(2, channels, length, dim)

    a, a_bias = fdl.fc_time.weight.detach(), fdl.fc_time.bias.detach()  # A (L_fre, L d), a (L_fre,)
    g, g_bias = fdl.fc_channel.weight.detach(), fdl.fc_channel.bias.detach()  # G (C_fre, C), g (C_fre,)
    weight = torch.kron(g, a)  # (C_fre L_fre, C L d): W[(f, m), (c, i)] = G[f, c] A[m, i]
    bias = torch.kron(g.sum(dim=1), a_bias) + torch.kron(g_bias, torch.ones_like(a_bias))  # (C_fre L_fre,)
    assert weight.shape == (out_channels * out_length, channels * length * dim)
    dense = paper.reshape(2, -1) @ weight.T + bias  # one FC over the whole flattened (C, L, d) input
    expected = apply_activation(dense, fdl.activation).view(2, out_channels, out_length)

    torch.testing.assert_close(fdl.project(mixed), expected)
    # The stored factors are the small ones: (L d + 1) L_fre + (C + 1) C_fre, not the dense size.
    fc_size = sum(p.numel() for n, p in fdl.named_parameters() if n.startswith("fc_"))
    assert fc_size == (length * dim + 1) * out_length + (channels + 1) * out_channels


def test_mixed_mode_keeps_its_parameter_names() -> None:
    """Checkpoints saved before ``output`` existed load strictly: same keys, no extra ones."""
    fdl = FrequencyDomainLearning(8, 4, embed_dim=2, out_channels=3, out_length=5)
    assert fdl.output is FDLOutput.MIXED and fdl.out_length == 5
    fc_keys = {k for k in fdl.state_dict() if k.startswith("fc")}
    assert fc_keys == {"fc_time.weight", "fc_time.bias", "fc_channel.weight", "fc_channel.bias"}
    assert fdl.fc_time.weight.shape == (5, 4 * 2) and fdl.fc_channel.weight.shape == (3, 8)


@pytest.mark.parametrize("activation", ["identity", "relu"])
def test_ordered_fc_is_one_dense_fc_per_time_step(activation: str) -> None:
    torch.manual_seed(7)
    channels, length, dim, out_channels = 6, 5, 3, 4
    fdl = FrequencyDomainLearning(
        channels, length, dim, out_channels, out_length=99, activation=activation, output="ordered"
    ).double()
    assert fdl.out_length == length  # out_length is not used: the L_res time steps are kept
    assert {k for k in fdl.state_dict() if k.startswith("fc")} == {"fc.weight", "fc.bias"}
    assert fdl.fc.weight.shape == (out_channels, channels * dim)  # dense (C_res x d) -> C_fre
    paper, mixed = _paper_tokens(2, channels, length, dim)
    out = fdl.project(mixed)
    assert out.shape == (2, out_channels, length)
    for t in range(length):  # step t: flatten (C, d) in that order (c d + k), FC, activation
        step = apply_activation(fdl.fc(paper[:, :, t, :].reshape(2, channels * dim)), fdl.activation)
        torch.testing.assert_close(out[:, :, t], step)


def test_ordered_fc_changes_only_the_step_it_is_given() -> None:
    """The FC stage alone: a change at time step j changes output step j and nothing else."""
    torch.manual_seed(8)
    channels, length, dim = 6, 7, 3
    fdl = FrequencyDomainLearning(channels, length, dim, 5, output="ordered").double()
    _, mixed = _paper_tokens(2, channels, length, dim)
    base = fdl.project(mixed)
    for j in range(length):
        bumped = mixed.clone()
        bumped[..., j] += torch.randn_like(bumped[..., j])  # (B, d, C) at step j
        changed = (fdl.project(bumped) - base).abs().amax(dim=(0, 1)) > 1e-12  # (L,)
        assert changed.tolist() == [t == j for t in range(length)], j


@pytest.mark.parametrize("residual", [False, True])
def test_ordered_fdl_is_time_local_without_the_temporal_learner(residual: bool) -> None:
    """Whole FDL, "ordered": only the temporal learner mixes time steps. With it set to identity
    (and a linear activation, so rfft -> irfft is exact), step j of the input reaches output step j
    only, whatever the channel learner and the residual do; with it learning, j reaches all steps."""
    torch.manual_seed(9)
    channels, length, dim = 8, 5, 3
    fdl = FrequencyDomainLearning(
        channels, length, dim, 4, activation="identity", residual=residual, output="ordered"
    )
    x = torch.randn(2, channels, length)
    bumped = x.clone()
    j = 2
    bumped[:, :, j] += 1.0
    learning = (fdl(bumped) - fdl(x)).abs().amax(dim=(0, 1)) > 1e-5  # (L,)
    assert learning.all()  # the temporal learner's spectrum MLP spreads step j over all steps

    with torch.no_grad():
        for layer in fdl.temporal_mlp.layers:
            layer.weight_real.copy_(torch.eye(dim))
            layer.weight_imag.zero_()
            layer.bias_real.zero_()
            layer.bias_imag.zero_()
    local = (fdl(bumped) - fdl(x)).abs().amax(dim=(0, 1)) > 1e-5
    assert local.tolist() == [t == j for t in range(length)]


def test_unknown_output_names_the_choices() -> None:
    with pytest.raises(ValueError, match=r"output must be one of 'mixed', 'ordered'.*got 'sorted'"):
        FrequencyDomainLearning(in_channels=8, in_length=4, output="sorted")
