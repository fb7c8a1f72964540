"""Pure helpers behind the scene's plots."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from app.services.features import CHANNEL_SPECTRUM, TEMPORAL_SPECTRUM, ModelInput, window_taps
from app.viz.palette import MODEL_COLORS, TRUTH_COLOR, WINDOW_COLOR, ColorBook, hex_color
from app.viz.spectra import (
    amplitude_spectrum,
    decimate_indices,
    heatmap_rgb,
    polyline_segments,
    position_error_per_window,
    velocity_error_per_window,
)
from ftin.checkpoint import load_model
from ftin.data import Trajectory
from ftin.data.readers.generic_csv import read_csv
from ftin.infer import predict_trajectory
from tests.utils.paths import CHECKPOINTS, REPO_ROOT


def test_amplitude_spectrum_finds_a_sine_and_ignores_the_mean() -> None:
    rate_hz, n = 100.0, 100
    t = np.arange(n) / rate_hz
    samples = np.stack([9.81 + 0.5 * np.sin(2 * np.pi * 2.0 * t), 0.2 * np.cos(2 * np.pi * 10.0 * t)], axis=1)
    before = samples.copy()
    freq, amplitude = amplitude_spectrum(samples, rate_hz)
    assert np.array_equal(samples, before)  # pure
    assert amplitude.shape == (2, 51) and freq[1] == pytest.approx(1.0) and freq[-1] == pytest.approx(50.0)
    assert freq[np.argmax(amplitude[0])] == pytest.approx(2.0) and amplitude[0].max() == pytest.approx(0.5)
    assert freq[np.argmax(amplitude[1])] == pytest.approx(10.0) and amplitude[1].max() == pytest.approx(0.2)
    assert amplitude[0, 0] == pytest.approx(0.0, abs=1e-12)  # gravity's DC removed
    with pytest.raises(ValueError, match="samples must be"):
        amplitude_spectrum(np.zeros(5), rate_hz)


def test_heatmap_puts_row_zero_at_the_bottom_and_fits_the_target() -> None:
    values = np.zeros((4, 3))
    values[0, 2] = 10.0  # lowest frequency bin, last column
    image = heatmap_rgb(values, target_px=(200, 300))
    assert image.dtype == np.uint8 and image.shape == (200, 300, 3)
    bright = image.sum(axis=2)
    assert bright[-1, -1] > bright[0, 0]  # bottom-right cell is the hot one
    assert heatmap_rgb(np.ones((65, 7))).shape[:2] == (65 * 3, 7 * 45)
    with pytest.raises(ValueError):
        heatmap_rgb(np.zeros(3))


def test_per_window_errors_against_ground_truth() -> None:
    t = np.linspace(0.0, 10.0, 101)
    truth = Trajectory(t, np.stack([t, np.zeros_like(t), np.ones_like(t)], axis=1))  # 1 m/s along x
    estimate = Trajectory(t, np.stack([t, 0.1 * t, np.zeros_like(t)], axis=1))  # drifts 0.1 m/s in y
    window_t = np.array([1.0, 5.0, 9.0])
    error = position_error_per_window(window_t, estimate, truth)
    assert error == pytest.approx([0.1, 0.5, 0.9])  # horizontal only: the 1 m z offset is ignored
    velocity = np.array([[1.0, 0.1], [1.0, 0.1], [2.0, 0.0]])
    v_error = velocity_error_per_window(window_t - 0.5, window_t + 0.5, velocity, truth)
    assert v_error == pytest.approx([0.1, 0.1, 1.0])


def test_decimation_and_segments() -> None:
    assert list(decimate_indices(5, 10)) == [0, 1, 2, 3, 4]
    keep = decimate_indices(10_001, 100)
    assert len(keep) == 100 and keep[0] == 0 and keep[-1] == 10_000
    segments = polyline_segments(np.arange(12.0).reshape(4, 3))
    assert segments.shape == (3, 2, 3) and np.array_equal(segments[1, 0], [3.0, 4.0, 5.0])


def test_window_taps_equal_those_of_the_full_inference_pass(
    checkpoint_dir: Path, sample_frame: pd.DataFrame
) -> None:
    """The scene recomputes one window's FDL spectra; they must be what the prediction computed."""
    loaded = load_model(checkpoint_dir / "ftin-oxiod")
    seq = read_csv(io.StringIO(sample_frame.head(400).to_csv(index=False)), name="walk")
    prediction = predict_trajectory(loaded, seq, return_features=True)
    starts = prediction.prepared.starts
    model_input = ModelInput(prediction.prepared.imu_world, starts, loaded.window, prediction.turn_stride)
    assert len(starts) == len(prediction.window_t_s) == 14
    for index in (0, 6, 13):
        taps = window_taps(loaded, model_input, index)
        assert set(taps) == {CHANNEL_SPECTRUM, TEMPORAL_SPECTRUM}
        for name, value in taps.items():
            expected = prediction.features[name][index].mean(axis=-1)  # mean over the embedding d
            assert value.dtype == np.float32 and value.shape == expected.shape
            np.testing.assert_allclose(value, expected, rtol=1e-4, atol=1e-6)
    assert taps[CHANNEL_SPECTRUM].shape == (9, 7) and taps[TEMPORAL_SPECTRUM].shape == (16, 4)
    # A model without FDL has nothing to show.
    assert window_taps(load_model(checkpoint_dir / "resnet-tiny"), model_input, 0) is None


def test_every_shipped_model_gets_its_own_colour() -> None:
    book = ColorBook()
    shipped = len(list(CHECKPOINTS.glob("*.safetensors")))
    count = max(20, shipped)  # a palette shorter than the shipped checkpoints fails here
    names = [f"model-{k}" for k in range(count)]
    colors = [book.color(name) for name in names]
    assert len(set(colors)) == count and TRUTH_COLOR not in colors and WINDOW_COLOR not in colors
    assert book.color("model-3") == colors[3]  # stable for the life of the scene
    assert hex_color((31, 119, 180)) == "#1f77b4"


def test_the_cursor_is_a_vertical_line_inserted_at_the_time() -> None:
    from app.viz.spectra import with_cursor

    x = np.array([0.0, 1.0, 2.0, 3.0])
    x2, (y2,), cursor = with_cursor(x, [np.array([0.0, 10.0, 20.0, 30.0])], 1.5)
    assert x2.tolist() == [0.0, 1.0, 1.5, 1.5, 2.0, 3.0]
    assert y2.tolist() == [0.0, 10.0, 15.0, 15.0, 20.0, 30.0]  # no gap in the curves
    assert np.isnan(cursor[[0, 1, 4, 5]]).all() and cursor[2] == 0.0 and cursor[3] == 1.0


def test_heading_error_of_a_rotated_walk_is_the_rotation_and_holds_while_standing() -> None:
    from app.viz.spectra import heading_error_per_window
    from ftin.data import Trajectory

    t = np.linspace(0.0, 40.0, 401)
    walking = np.minimum(t, 20.0)  # walks east for 20 s, then stands
    truth = Trajectory(t, np.stack([walking, np.zeros_like(t), np.zeros_like(t)], axis=1))
    yaw = np.radians(30.0)
    rotated = np.stack([walking * np.cos(yaw), walking * np.sin(yaw), np.zeros_like(t)], axis=1)
    error = heading_error_per_window(t[::10], Trajectory(t, rotated), truth)
    assert np.allclose(error[:15], 30.0, atol=1e-6)
    assert np.allclose(error[-5:], 30.0, atol=1e-6)  # standing: the last defined error is held


def test_the_upload_page_colours_models_like_the_scene() -> None:
    script = (REPO_ROOT / "static" / "util.js").read_text()  # the page's shared constants
    listed = re.search(r"const MODEL_COLORS = \[(.*?)\];", script, re.S)
    assert listed is not None
    assert re.findall(r'"(#[0-9a-f]{6})"', listed.group(1)) == [hex_color(c) for c in MODEL_COLORS]
