"""A live walk's path is continued, never redrawn: each update sends a bounded number of points, the
frozen chunks and the tail join into one unbroken line, and it ends at the walker."""

from __future__ import annotations

import numpy as np

from app.viz.live_path import CHUNK_POINTS, POINT_EVERY_S, SETTLED_S, GrowingPath
from ftin.data import Trajectory


class Line:
    def __init__(self, segments: np.ndarray) -> None:
        self.points = segments


class RecordingScene:
    """Only what ``GrowingPath`` calls: every line added, by name."""

    def __init__(self) -> None:
        self.lines: dict[str, Line] = {}
        self.added = 0

    def add_line_segments(self, name: str, segments: np.ndarray, *_: object, **__: object) -> Line:
        self.added += 1
        self.lines[name] = Line(segments)
        return self.lines[name]


def walk(minutes: float, rate_hz: float = 100.0) -> Trajectory:
    t = np.arange(0.0, 60.0 * minutes, 1.0 / rate_hz)
    p = np.column_stack([np.cos(t / 20.0) * 10.0, np.sin(t / 20.0) * 10.0, np.zeros_like(t)])
    return Trajectory(t, p)


def test_each_update_sends_a_bounded_tail_and_the_chunks_join_into_the_whole_path() -> None:
    whole, scene = walk(10.0), RecordingScene()
    path = GrowingPath(scene, "/runs/r", (1, 2, 3), from_t_s=10.0)
    bound = CHUNK_POINTS + SETTLED_S / POINT_EVERY_S + 2
    for end_s in np.arange(10.5, 600.0, 0.5):
        n = int(np.searchsorted(whole.t_s, end_s, side="right"))
        sent = path.grow(whole.slice(0, n))
        assert len(sent) <= bound
        np.testing.assert_allclose(sent[-1], whole.p_world_m[n - 1])  # the line reaches the walker
    chunks = [name for name in scene.lines if name != "/runs/r/live_tail"]
    assert len(chunks) >= 5  # ten minutes froze into chunks, not one ever-growing line
    assert scene.added == len(chunks) + 1  # every chunk sent once, the tail created once
    segments = np.concatenate([scene.lines[n].points for n in [*chunks, "/runs/r/live_tail"]])
    np.testing.assert_allclose(segments[1:, 0], segments[:-1, 1], atol=1e-5)  # no gap, no overlap
    np.testing.assert_allclose(segments[0, 0], whole.p_world_m[1000], atol=1e-5)  # from where it was drawn
    spacing = np.linalg.norm(np.diff(segments[:, 0, :2], axis=0), axis=1)
    assert spacing.max() < 2 * POINT_EVERY_S * 0.5 + 1e-3  # every 0.1 s of a 0.5 m/s walk
