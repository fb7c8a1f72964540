"""The generic CSV's columns: the canonical names, the aliases accepted for them, units in headers,
and how a header row is matched to them (one table, ``COLUMNS``; ``schema_markdown()`` renders it
for the README and the upload page).

Header names are matched case-insensitively after trimming whitespace, a UTF-8 BOM and a leading
``#``; punctuation and spaces become ``_``. Aliases from common phone loggers (Sensor Logger,
phyphox, Android/RoNIN-style names, ``ax``/``gx``, rotation-vector quaternions) live in ``COLUMNS``.
Units written in the header (``time [ns]``, ``gyro_x_deg_s``, ``Acceleration x (g)``) are parsed
here; ``ftin.data.readers.generic_csv`` converts them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

from ftin.data.errors import DataFormatError
from ftin.data.messages import Note
from ftin.data.validate import MAX_RATE_HZ, MIN_RATE_HZ, STANDARD_GRAVITY_M_S2


@dataclass(frozen=True)
class ColumnSpec:
    """One canonical column of the format and the header names accepted for it."""

    name: str
    group: str  # "t", "gyro", "acc", "q", "gt" or "mag": columns of a group come together
    unit: str
    meaning: str
    required: bool
    aliases: tuple[str, ...]


def _axis_aliases(prefixes: Sequence[str], axis: str, short: Sequence[str] = ()) -> tuple[str, ...]:
    # ``gyro_x`` and, for one-word prefixes, ``gyrox``; then short forms such as ``gx``
    glued = [f"{p}{axis}" for p in prefixes if "_" not in p]
    return tuple(dict.fromkeys([f"{p}_{axis}" for p in prefixes] + glued + [s + axis for s in short]))


_GYRO_PREFIXES = ("gyro", "gyr", "gyroscope", "angular_velocity", "angular_rate", "rotation_rate", "omega")
_ACC_PREFIXES = (
    "acc",
    "acce",
    "accel",
    "accelerometer",
    "acceleration",
    "total_acceleration",
    "totalacceleration",
    "specific_force",
)
_Q_PREFIXES = (
    "q",
    "quat",
    "quaternion",
    "orientation",
    "attitude",
    "rv",
    "rotation_vector",
    "game_rv",
    "grv",
    "game_rotation_vector",
    "q_world_device",
)
_MAG_PREFIXES = ("mag", "magnet", "magnetometer", "magnetic_field", "magn", "magnetometer_calibrated")
_GT_PREFIXES = ("gt", "gt_p", "gt_pos", "gt_position", "pos", "position", "p", "p_world", "gt_device_world")
# Ground truth under this name is in the orientation's world frame (what ``write_csv`` writes from
# our readers' output); any other name may be in its own world frame (see ``meta["gt_frame"]``).
GT_DEVICE_WORLD_PREFIX = "gt_device_world"


def _axis_columns(
    group: str,
    unit: str,
    required: bool,
    prefixes: Sequence[str],
    meaning: str,
    axes: str = "xyz",
    short: Sequence[str] = (),
) -> tuple[ColumnSpec, ...]:
    """The columns ``{group}_{axis}`` of one group; ``meaning`` names the axis with ``{}``."""
    return tuple(
        ColumnSpec(
            f"{group}_{a}", group, unit, meaning.format(a), required, _axis_aliases(prefixes, a, short)
        )
        for a in axes
    )


COLUMNS: tuple[ColumnSpec, ...] = (
    ColumnSpec(
        "t",
        "t",
        "s",
        "sample time (s, ms, us or ns: detected and reported)",
        True,
        (
            "t",
            "t_s",
            "time_s",
            "seconds_elapsed",
            "time",
            "times",
            "timestamp",
            "timestamps",
            "seconds",
            "sec",
            "elapsed",
        ),
    ),
    *_axis_columns(
        "gyro", "rad/s", True, _GYRO_PREFIXES, short=("g", "w_"), meaning="angular rate about device {}"
    ),
    *_axis_columns(
        "acc",
        "m/s^2",
        True,
        _ACC_PREFIXES,
        short=("a", "f_"),
        meaning="specific force along device {}, gravity included",
    ),
    *_axis_columns(
        "q",
        "-",
        False,
        _Q_PREFIXES,
        axes="wxyz",
        meaning="orientation world-from-device, quaternion {} (scalar w)",
    ),
    *_axis_columns(
        "gt",
        "m",
        False,
        _GT_PREFIXES,
        meaning="ground-truth position {0}; `gt_device_world_{0}` when in the orientation's world frame",
    ),
    *_axis_columns(
        "mag",
        "µT",
        False,
        _MAG_PREFIXES,
        short=("m",),
        meaning="magnetic field along device {} (µT; nT, mT, gauss or mG in the header are converted): "
        "lets the orientation filter reference its heading to magnetic north",
    ),
)

GROUPS: dict[str, tuple[str, ...]] = {}
for _spec in COLUMNS:
    GROUPS.setdefault(_spec.group, ())
    GROUPS[_spec.group] += (_spec.name,)

# alias -> (canonical name, priority: lower wins when several aliases of one column are present)
ALIASES: dict[str, tuple[str, int]] = {}
for _spec in COLUMNS:
    for _rank, _alias in enumerate(_spec.aliases):
        if _alias in ALIASES and ALIASES[_alias][0] != _spec.name:
            raise RuntimeError(f"alias {_alias!r} is claimed by {ALIASES[_alias][0]} and {_spec.name}")
        ALIASES.setdefault(_alias, (_spec.name, _rank))

# Unit spellings (after lower-casing and removing spaces) -> canonical unit.
_UNITS: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "μs", "usec", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanosecond", "nanoseconds"), "ns"),
    **dict.fromkeys(("rad/s", "rads-1", "rad/sec", "rad_s", "rads", "rad_per_s", "radps"), "rad/s"),
    **dict.fromkeys(("deg/s", "degs-1", "°/s", "dps", "deg_s", "degps", "deg_per_s", "degree/s"), "deg/s"),
    **dict.fromkeys(("m/s2", "ms-2", "m_s2", "ms2", "mps2", "m/s/s", "m_s_2", "m/s^2"), "m/s^2"),
    **dict.fromkeys(("g", "gee"), "g"),
    **dict.fromkeys(("m", "meter", "meters", "metre", "metres"), "m"),
    **dict.fromkeys(("ut", "µt", "μt", "microtesla", "microteslas", "micro_t"), "uT"),
    **dict.fromkeys(("nt", "nanotesla", "nanoteslas"), "nT"),
    **dict.fromkeys(("mt", "millitesla", "milliteslas"), "mT"),
    **dict.fromkeys(("gauss", "gs"), "gauss"),
    **dict.fromkeys(("mgauss", "milligauss", "mgs"), "mG"),
}
# Unit suffixes seen glued to names (``gyro_x_rad_s``) -> canonical unit; longest tried first.
_UNIT_SUFFIXES: dict[str, str] = {
    "rad_per_s": "rad/s",
    "rad_s": "rad/s",
    "rads": "rad/s",
    "deg_per_s": "deg/s",
    "deg_s": "deg/s",
    "dps": "deg/s",
    "m_s_2": "m/s^2",
    "m_s2": "m/s^2",
    "mps2": "m/s^2",
    "ms2": "m/s^2",
    "s": "s",
    "ms": "ms",
    "us": "us",
    "ns": "ns",
    "g": "g",
    "m": "m",
    "ut": "uT",
    "nt": "nT",
}
# Aliases whose name states the unit.
_IMPLIED_UNITS = {"t_s": "s", "time_s": "s", "seconds_elapsed": "s", "seconds": "s", "sec": "s"}
# Multiply a value in the key unit to get the canonical unit of its group.
TO_CANONICAL = {
    "t": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "gyro": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "acc": {"m/s^2": 1.0, "g": STANDARD_GRAVITY_M_S2},
    "gt": {"m": 1.0},
    "mag": {"uT": 1.0, "nT": 1e-3, "mT": 1e3, "gauss": 100.0, "mG": 0.1},
}
TIME_UNIT_WORDS = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}


def schema_markdown() -> str:
    """The column table as Markdown (for the README and the web upload page)."""
    lines = [
        "| column | required | unit | meaning | accepted header names (case-insensitive) |",
        "|---|---|---|---|---|",
    ]
    for spec in COLUMNS:
        aliases = ", ".join(f"`{a}`" for a in spec.aliases if a != spec.name)
        required = "yes" if spec.required else f"no (all of {', '.join(GROUPS[spec.group])})"
        lines.append(f"| `{spec.name}` | {required} | {spec.unit} | {spec.meaning} | {aliases} |")
    lines.append("")
    lines.append(
        "Units may be written in the header, e.g. `time [ns]`, `gyro_x_deg_s`, `Acceleration x (g)`: "
        "they are converted. Without a unit, `t` may be in s, ms, us or ns (detected from the sample "
        f"interval; the rate must be {MIN_RATE_HZ:g}–{MAX_RATE_HZ:g} Hz)."
    )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Header parsing


@dataclass(frozen=True)
class HeaderMatch:
    index: int  # column position in the file
    header: str  # as written
    canonical: str
    rank: int
    unit: str | None  # canonical unit written in the header, if any


def _canonical_unit(text: str) -> str | None:
    key = text.strip().lower().replace(" ", "").replace("²", "2").replace("^", "").replace("−", "-")
    return _UNITS.get(key)


def match_header(index: int, header: str) -> HeaderMatch | None:
    """Map one header cell to a canonical column, or None when it is not one of ours."""
    text = header.replace("\ufeff", "").strip().lstrip("#").strip()
    unit: str | None = None
    bracketed = re.findall(r"[\[(]([^\])]*)[\])]", text)
    if bracketed:
        unit = _canonical_unit(bracketed[-1])
        text = re.sub(r"[\[(][^\])]*[\])]", " ", text)
    key = re.sub(r"[^a-z0-9µμ]+", "_", text.lower()).strip("_")
    if key in ALIASES:
        name, rank = ALIASES[key]
        return HeaderMatch(index, header, name, rank, unit or _IMPLIED_UNITS.get(key))
    for suffix in sorted(_UNIT_SUFFIXES, key=len, reverse=True):
        stem = key[: -len(suffix) - 1]
        if key.endswith("_" + suffix) and stem in ALIASES:
            name, rank = ALIASES[stem]
            return HeaderMatch(index, header, name, rank, unit or _UNIT_SUFFIXES[suffix])
    return None


def map_columns(
    headers: Sequence[str], source: str, matches: Sequence[HeaderMatch | None] | None = None
) -> tuple[dict[str, HeaderMatch], list[str]]:
    """Canonical name -> chosen header; plus warnings about ignored columns. ``matches``: each
    header's ``match_header`` where the caller has it already (a header is matched once)."""
    warnings: list[str] = []
    candidates: dict[str, list[HeaderMatch]] = {}
    unknown: list[str] = []
    for i, header in enumerate(headers):
        match = match_header(i, header) if matches is None else matches[i]
        if match is None:
            if header.strip():
                unknown.append(shown(header.strip()))
            continue
        candidates.setdefault(match.canonical, []).append(match)
    chosen: dict[str, HeaderMatch] = {}
    for name, matches in candidates.items():
        matches = sorted(matches, key=lambda m: m.rank)
        if len(matches) > 1 and matches[0].rank == matches[1].rank:
            raise DataFormatError(
                f"{source}: columns {matches[0].header.strip()!r} (column {matches[0].index + 1}) and "
                f"{matches[1].header.strip()!r} (column {matches[1].index + 1}) both mean {name!r}; keep one"
            )
        chosen[name] = matches[0]
        if len(matches) > 1:
            others = ", ".join(repr(m.header.strip()) for m in matches[1:])
            warnings.append(Note(f"used column {matches[0].header.strip()!r} for {name}; ignored {others}"))
    if unknown:
        warnings.append(Note("ignored columns: " + listed(unknown)))
    return chosen, warnings


MAX_LISTED = 24  # header names a message lists: an error body stays short however wide the file


def listed(names: Sequence[str]) -> str:
    """``names`` comma-separated, the first ``MAX_LISTED`` of them and a count of the rest; each name
    cut at 60 characters."""
    parts = [n if len(n) <= 60 else n[:57] + "..." for n in names[:MAX_LISTED]]
    more = f" and {len(names) - MAX_LISTED} more ({len(names)} in all)" if len(names) > MAX_LISTED else ""
    return ", ".join(parts) + more


def shown(cell: str) -> str:
    """A header cell as messages show it: as written, or quoted with escapes when it holds line breaks or
    control characters (messages stay one line)."""
    return cell if cell.isprintable() else repr(cell)


def missing_required(chosen: dict[str, HeaderMatch]) -> list[str]:
    return [spec.name for spec in COLUMNS if spec.required and spec.name not in chosen]


def split_header_line(line: str) -> list[str]:
    return line.rstrip("\r\n").split(sniff_delimiter(line))


def sniff_delimiter(header_line: str) -> str:
    # Comma unless the header clearly uses another separator (European CSV, TSV exports).
    counts = {sep: header_line.count(sep) for sep in (",", ";", "\t")}
    best = max(counts, key=lambda sep: counts[sep])
    return best if counts[best] > 0 else ","


def looks_numeric(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def header_line_matches(line: str) -> bool:
    """True when a header line names all required columns (or their aliases)."""
    cells = split_header_line(line)
    matches = [match_header(i, cell) for i, cell in enumerate(cells)]
    return names_required({m.canonical for m in matches if m is not None})


def names_required(names: set[str]) -> bool:
    """True when the canonical ``names`` found in a header include every required column."""
    return all(spec.name in names for spec in COLUMNS if spec.required)
