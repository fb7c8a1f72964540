"""The app's embedded sample sequences: small simulated walks shipped as generic CSV.

``python -m ftin.sim.samples`` regenerates the files in ``ftin/sim/samples/`` from ``SAMPLES``;
``python -m ftin.sim.samples --check`` only verifies that the shipped files are up to date.

Decision: values are stored at a fixed precision (``STORAGE_DECIMALS``) far below the simulated
sensor noise (gyro 1e-6 rad/s against ~2e-3 rad/s noise, accelerometer 1e-5 m/s² against ~2e-2),
which keeps all samples together near 5 MB instead of ~10 MB at full float precision. A shipped file
therefore equals ``simulate(SAMPLES[name])`` to within half a storage unit per value; the tests
check exactly that, so the files cannot go stale.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ftin.data.readers.generic_csv import read_csv, write_csv
from ftin.data.types import ImuSequence, Trajectory
from ftin.sim.config import CarryMode, SimConfig
from ftin.sim.simulator import simulate

SAMPLES_DIR = Path(__file__).resolve().parent / "samples"


def write_walks(
    out: Path, count: int, duration_s: float = 120.0, rate_hz: float = 100.0, seed: int = 0
) -> list[Path]:
    """Simulate ``count`` walks cycling through the carry modes (walk i seeded ``seed + i``) as CSV
    files in ``out`` (``ftin sim``, the campaign's simulator data)."""
    out.mkdir(parents=True, exist_ok=True)
    carries, written = list(CarryMode), []
    for i in range(count):
        carry = carries[i % len(carries)]
        name = f"sim_{seed + i:04d}_{carry.value}"
        config = SimConfig(duration_s=duration_s, rate_hz=rate_hz, carry=carry, seed=seed + i, name=name)
        write_csv(simulate(config), out / f"{name}.csv")
        written.append(out / f"{name}.csv")
    return written


SAMPLES: dict[str, SimConfig] = {
    "sim_handheld": SimConfig(duration_s=90.0, rate_hz=100.0, carry=CarryMode.HANDHELD, seed=11),
    "sim_pocket": SimConfig(duration_s=90.0, rate_hz=100.0, carry=CarryMode.POCKET, seed=12),
    "sim_trolley": SimConfig(duration_s=90.0, rate_hz=100.0, carry=CarryMode.TROLLEY, seed=13),
    "sim_stops_turns": SimConfig(
        duration_s=120.0,
        rate_hz=100.0,
        carry=CarryMode.HANDHELD,
        seed=14,
        leg_duration_range_s=(3.0, 8.0),
        turn_probability=1.0,
        stop_probability=0.5,
    ),
}

# Decimal places stored per column group; t = i / rate is short in repr already.
STORAGE_DECIMALS = {"gyro": 6, "acc": 5, "q": 9, "gt": 6}


def _unknown(name: str) -> KeyError:
    return KeyError(f"unknown sample {name!r}; valid samples: {', '.join(SAMPLES)}")


def sample_path(name: str, directory: Path = SAMPLES_DIR) -> Path:
    if name not in SAMPLES:
        raise _unknown(name)
    return Path(directory) / f"{name}.csv"


def storage_rounded(seq: ImuSequence) -> ImuSequence:
    """``seq`` at the stored precision (what the CSV holds); quaternions are not renormalised."""
    d = STORAGE_DECIMALS

    def rounded(values: np.ndarray, group: str) -> np.ndarray:
        return np.round(values, d[group]) + 0.0  # + 0.0 turns -0.0 into 0.0

    q = None if seq.q_world_device_wxyz is None else rounded(seq.q_world_device_wxyz, "q")
    gt = None
    if seq.gt is not None:
        gt_q = None if seq.gt.q_world_body_wxyz is None else rounded(seq.gt.q_world_body_wxyz, "q")
        gt = Trajectory(seq.gt.t_s, rounded(seq.gt.p_world_m, "gt"), gt_q)
    return seq.with_(
        gyro_rad_s=rounded(seq.gyro_rad_s, "gyro"),
        acc_m_s2=rounded(seq.acc_m_s2, "acc"),
        q_world_device_wxyz=q,
        gt=gt,
    )


def write_samples(directory: Path = SAMPLES_DIR) -> list[Path]:
    """Simulate every sample and write it as ``<directory>/<name>.csv``."""
    paths = []
    for name, config in SAMPLES.items():
        path = sample_path(name, directory)
        write_csv(storage_rounded(simulate(config)), path)
        paths.append(path)
    return paths


def load_sample(name: str, directory: Path = SAMPLES_DIR) -> ImuSequence:
    """Read a shipped sample, with the simulation's facts (carry, seed, orientation) in ``meta``."""
    config = SAMPLES.get(name)
    if config is None:
        raise _unknown(name)
    seq = read_csv(sample_path(name, directory), name=name)
    meta = {
        **seq.meta,
        "dataset": "sim",
        "carry": config.carry.value,
        "seed": config.seed,
        # The stored orientation is the exact simulated one (see ftin.sim.simulator).
        "orientation_source": "ground_truth",
    }
    return seq.with_(meta=meta)


def stale_samples(directory: Path = SAMPLES_DIR) -> list[str]:
    """Names of samples whose file is missing or differs from ``simulate(SAMPLES[name])`` by more
    than the storage rounding."""
    stale = []
    for name, config in SAMPLES.items():
        path = sample_path(name, directory)
        if not path.is_file() or not matches_simulation(load_sample(name, directory), simulate(config)):
            stale.append(name)
    return stale


def matches_simulation(stored: ImuSequence, simulated: ImuSequence) -> bool:
    """True when ``stored`` is ``simulated`` at the storage precision: half a unit, plus 1e-9 for the
    reader's quaternion renormalisation and for float noise across library versions (a value that sat
    on a rounding boundary when the file was written may round the other way: scipy 1.17 moved one
    acceleration by 1.7e-11 past the half unit). Another seed differs by whole units."""
    if len(stored) != len(simulated) or stored.gt is None or stored.q_world_device_wxyz is None:
        return False
    pairs = {
        "gyro": (stored.gyro_rad_s, simulated.gyro_rad_s),
        "acc": (stored.acc_m_s2, simulated.acc_m_s2),
        "q": (stored.q_world_device_wxyz, simulated.q_world_device_wxyz),
        "gt": (stored.gt.p_world_m, simulated.gt.p_world_m),
    }
    if not np.array_equal(stored.t_s, simulated.t_s):
        return False
    for group, (a, b) in pairs.items():
        # q: the reader renormalises, which moves a component by up to one more storage unit.
        units = 1.5 if group == "q" else 0.5
        if np.max(np.abs(a - b)) > units * 10.0 ** -STORAGE_DECIMALS[group] + 1e-9:
            return False
    return True


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ftin.sim.samples", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=SAMPLES_DIR, help="folder to write (default: package)")
    parser.add_argument("--check", action="store_true", help="only check that the files are up to date")
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_samples(args.out)
        for name in stale:
            print(f"stale or missing: {sample_path(name, args.out)}", file=sys.stderr)
        if not stale:
            print(f"{len(SAMPLES)} samples in {args.out} are up to date")
        return 1 if stale else 0
    for path in write_samples(args.out):
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
