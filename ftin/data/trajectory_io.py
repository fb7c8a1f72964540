"""Trajectories out of the workbench: the TUM format (what ``evo_ape tum gt.txt est.txt`` reads) and
resampling a trajectory at other timestamps (the input's own, on request).

TUM RGB-D format: one line per pose, ``timestamp tx ty tz qx qy qz qw`` separated by spaces, a ``#``
comment header allowed; timestamps in seconds, positions in metres, the quaternion scalar-last
(our ``wxyz`` is converted here, at the boundary). Decisions:

* A trajectory without orientations (a ground truth given as positions only) is written with the
  identity quaternion, and the header comment says so: evo's translation errors (``APE`` with the
  default ``translation_part``) do not read it.
* Numbers are written with ``repr`` precision (round-trip exact), so ``read_tum(tum_text(t))`` gives
  the same arrays back.
"""

from __future__ import annotations

import io

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.types import Trajectory


def tum_text(traj: Trajectory, comment: str | None = None) -> str:
    """``traj`` as TUM text (see the module docstring)."""
    q_wxyz = traj.q_world_body_wxyz
    lines = ["# timestamp tx ty tz qx qy qz qw"]
    if comment:
        lines.extend(f"# {line}" for line in comment.splitlines())
    if q_wxyz is None:
        lines.append("# no orientation in this trajectory: identity quaternions (positions only)")
        q_xyzw = np.tile([0.0, 0.0, 0.0, 1.0], (len(traj), 1))
    else:
        q_xyzw = np.asarray(q_wxyz)[:, [1, 2, 3, 0]]
    table = np.column_stack([traj.t_s, traj.p_world_m, q_xyzw])
    out = io.StringIO()
    out.write("\n".join(lines) + "\n")
    for row in table:
        out.write(" ".join(repr(float(v)) for v in row) + "\n")
    return out.getvalue()


def read_tum(text: str, source: str = "TUM file") -> Trajectory:
    """Parse TUM text (comments and blank lines skipped) into a ``Trajectory``."""
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        cells = line.replace(",", " ").split()
        if len(cells) != 8:
            raise DataFormatError(f"{source}: line {number} has {len(cells)} values; TUM lines have 8")
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            raise DataFormatError(f"{source}: line {number} holds a value that is not a number") from None
    if not rows:
        raise DataFormatError(f"{source}: no poses")
    table = np.asarray(rows)
    return Trajectory(table[:, 0], table[:, 1:4], table[:, [7, 4, 5, 6]])


def at_times(traj: Trajectory, t_s: np.ndarray) -> Trajectory:
    """``traj`` at the timestamps ``t_s`` inside its span (linear positions, Slerp orientations);
    timestamps outside its span are dropped, never extrapolated."""
    t = np.asarray(t_s, dtype=np.float64)
    inside = t[(t >= traj.t_s[0] - 1e-9) & (t <= traj.t_s[-1] + 1e-9)]
    query = np.clip(inside, traj.t_s[0], traj.t_s[-1])
    p = np.column_stack([np.interp(query, traj.t_s, traj.p_world_m[:, j]) for j in range(3)])
    q = None
    if traj.q_world_body_wxyz is not None:
        rotations: Rotation = frames.rotation_from_wxyz(traj.q_world_body_wxyz)
        q = frames.make_continuous(frames.wxyz_from_rotation(Slerp(traj.t_s, rotations)(query)))
    return Trajectory(inside, p, q)
