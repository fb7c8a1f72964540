"""``ftin.bench.profile`` (``ftin models``): FLOP counting on known cases, threads, profiling rows."""

from __future__ import annotations

import math

import pytest
import torch
from torch import nn

from ftin.bench.profile import (
    flops_per_window,
    profile_model,
    profile_models,
    torch_threads,
    windows_per_second,
)
from ftin.models import UnknownModelError, create_model


def test_flops_of_conv_and_linear_match_the_closed_form():
    model = nn.Sequential(nn.Conv1d(6, 8, 3, padding=1), nn.Flatten(), nn.Linear(8 * 50, 4))
    expected = 2 * 8 * 6 * 3 * 50 + 2 * 400 * 4
    assert flops_per_window(model, 50) == expected


def test_flops_count_lstm_gates_bilinear_and_fft():
    class Recurrent(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.lstm = nn.LSTM(6, 7, num_layers=2, bidirectional=True, batch_first=True)

        def forward(self, x):
            return self.lstm(x.transpose(1, 2))[0]

    # per layer and direction: 2 x T x (4H x I + 4H x H); layer 2 sees both directions (2H inputs)
    expected = 2 * (2 * 10 * (28 * 6 + 28 * 7)) + 2 * (2 * 10 * (28 * 14 + 28 * 7))
    assert flops_per_window(Recurrent(), 10) == expected

    class Bilinear(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.bilinear = nn.Bilinear(6, 6, 24)

        def forward(self, x):
            frames = x.transpose(1, 2)
            return self.bilinear(frames, frames)

    assert flops_per_window(Bilinear(), 10) == 2 * 10 * 24 * 6 * 6

    class Spectrum(nn.Module):
        def forward(self, x):
            return torch.fft.irfft(torch.fft.rfft(x, dim=2), n=x.shape[2], dim=2)

    n = 64
    assert flops_per_window(Spectrum(), n) == round(2 * 2.5 * n * math.log2(n) * 6)


def test_ronin_lstm_flops_include_its_lstm():
    t = 100
    lstm = 2 * t * (400 * 30 + 400 * 100) + 2 * 2 * t * (400 * 100 + 400 * 100)
    bilinear = 2 * t * 24 * 6 * 6
    linears = 2 * t * (130 * 10 + 10 * 2)
    assert flops_per_window(create_model("ronin_lstm"), t) == lstm + bilinear + linears


def test_profile_restores_threads_and_mode():
    model = create_model("ronin_tcn").train()
    before = torch.get_num_threads()
    with torch_threads(2) as used:
        assert used == 2 == torch.get_num_threads()
    assert torch.get_num_threads() == before
    assert windows_per_second(model, 64, batch=4, threads=1, repeats=1) > 0
    assert model.training and torch.get_num_threads() == before
    with pytest.raises(ValueError, match="threads must be >= 1"):
        with torch_threads(0):
            pass


def test_profile_model_reports_counts_speed_and_unsupported_windows():
    row = profile_model("ronin_tcn", window=64, batch=4, threads=1, repeats=1)
    assert row.parameters == 540_488  # the reference TCN (tests/models/test_param_counts.py)
    assert row.flops_per_window == flops_per_window(create_model("ronin_tcn"), 64)
    assert row.windows_per_s is not None and row.windows_per_s > 0
    assert (row.threads, row.batch, row.out_dim, row.has_uncertainty, row.error) == (1, 4, 2, False, None)
    skipped = profile_model("imunet", window=64, batch=4, measure_speed=False)
    assert skipped.parameters is None and "imunet: window must be >= 65" in skipped.error
    no_speed = profile_models(["tlio"], window=64, measure_speed=False)[0]
    assert no_speed.windows_per_s is None and no_speed.has_uncertainty and no_speed.out_dim == 3
    with pytest.raises(UnknownModelError, match="valid models: .*ronin_resnet"):
        profile_models(["ronin_resnet", "nope"])
