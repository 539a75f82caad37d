"""Records for calibration: load EMPS ``.mat`` files and CSV logs into one :class:`Record`.

A record holds, on a uniform time base, the drive torque at the axis and the measured position
(and optionally velocity and motor current). Rotary records use rad / N·m; *linear* records
(``linear=True``: ball screws such as EMPS) use m / N and the report translates parameter names
(``period_m``, ``amplitude_n``).

Formats
-------
* EMPS benchmark ``.mat`` (Janot, Gautier & Brunot 2019): ``t`` [s], ``qm`` [m], ``vir`` [V],
  ``gtau`` [N/V]; force = ``gtau*vir`` [N]. ``qg``, ``kp``, ``kv`` and (PULSES file) ``pulses_N``
  are kept in :attr:`Record.extra` for the closed-loop simulation. Always linear.
* CSV with a header row and columns ``time_s``, ``torque_nm``, ``position_rad`` and optionally
  ``velocity_rad_s``, ``current_a``. ``columns={"time_s": "t", ...}`` maps the canonical names
  to the file's names (CLI: ``--columns time_s=t,torque_nm=tau``). With ``linear=True`` the
  columns hold metres and newtons (names unchanged, or mapped).
* The ``sensor.log`` that ``schmidt-fil run`` writes (:func:`load_sensor_log`): torque from
  the logged motor currents, position from the QEI counts; ``--axis`` picks RA or DEC.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Record", "RecordError", "load_record", "load_emps", "load_csv", "load_sensor_log", "parse_columns",
           "write_csv"]

REQUIRED_COLUMNS = ("time_s", "torque_nm", "position_rad")
OPTIONAL_COLUMNS = ("velocity_rad_s", "current_a")


class RecordError(ValueError):
    """A record file could not be read; the message names the file, the column and what was expected."""


@dataclasses.dataclass
class Record:
    """One measured (or generated) record on a uniform time base.

    Attributes
    ----------
    name : str
        Short name (file stem).
    t_s : ndarray, shape (N,)
        Time [s], uniformly sampled.
    position : ndarray, shape (N,)
        Measured position [rad] (linear: [m]).
    torque : ndarray, shape (N,)
        Drive torque at the axis [N·m] (linear: force [N]).
    velocity : ndarray or None
        Measured velocity [rad/s] (linear: [m/s]) if the record has it (not used by the fit,
        which differentiates the filtered position as the EMPS reference procedure does).
    current_a : ndarray or None
        Motor current [A] if present.
    linear : bool
        True for linear drives (units m, N).
    source : str
        Path it was read from.
    extra : dict
        Format-specific signals (EMPS: ``qg``, ``gtau``, ``kp``, ``kv``, ``vir``, ``pulses``).
    """

    name: str
    t_s: np.ndarray
    position: np.ndarray
    torque: np.ndarray
    velocity: np.ndarray | None = None
    current_a: np.ndarray | None = None
    linear: bool = False
    source: str = ""
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def dt_s(self) -> float:
        """Sample period [s] (median of the time differences)."""
        return float(np.median(np.diff(self.t_s)))

    @property
    def units(self) -> dict[str, str]:
        """Unit strings for position, velocity, torque."""
        if self.linear:
            return {"position": "m", "velocity": "m/s", "torque": "N"}
        return {"position": "rad", "velocity": "rad/s", "torque": "N·m"}

    def __len__(self) -> int:
        return int(self.t_s.size)


def _check_uniform(path: Path, t: np.ndarray) -> None:
    if t.size < 200:
        raise RecordError(f"{path}: column 'time_s' has {t.size} samples; expected at least 200")
    d = np.diff(t)
    if not np.all(np.isfinite(t)):
        raise RecordError(f"{path}: column 'time_s' contains non-finite values")
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise RecordError(f"{path}: column 'time_s' must increase strictly; it does not at row {i + 2}")
    med = np.median(d)
    if np.max(np.abs(d - med)) > 0.01 * med:
        raise RecordError(
            f"{path}: column 'time_s' must be uniformly sampled (spacing {med:g} s); "
            f"spacing varies between {d.min():g} and {d.max():g} s — resample first"
        )


def load_emps(path: str | Path) -> Record:
    """Load an EMPS benchmark ``.mat`` file (``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat``).

    Returns
    -------
    Record
        Linear record: position ``qm`` [m], force ``gtau*vir`` [N].

    Raises
    ------
    RecordError
        A required variable (``t``, ``qm``, ``vir``, ``gtau``) is missing.
    """
    from scipy.io import loadmat

    path = Path(path)
    try:
        d = loadmat(str(path))
    except Exception as exc:  # scipy raises several kinds
        raise RecordError(f"{path}: cannot read as a MATLAB file ({exc})") from exc
    for key in ("t", "qm", "vir", "gtau"):
        if key not in d:
            have = sorted(k for k in d if not k.startswith("__"))
            raise RecordError(f"{path}: variable {key!r} missing; expected EMPS variables t, qm, vir, gtau (have {have})")
    t = np.asarray(d["t"], float).ravel()
    _check_uniform(path, t)
    gtau = float(np.asarray(d["gtau"]).ravel()[0])
    vir = np.asarray(d["vir"], float).ravel()
    extra: dict[str, Any] = {"gtau": gtau, "vir": vir, "format": "emps"}
    for key in ("qg", "kp", "kv", "pulses_N"):
        if key in d:
            arr = np.asarray(d[key], float).ravel()
            extra["pulses" if key == "pulses_N" else key] = float(arr[0]) if arr.size == 1 else arr
    return Record(
        name=path.stem,
        t_s=t,
        position=np.asarray(d["qm"], float).ravel(),
        torque=gtau * vir,
        linear=True,
        source=str(path),
        extra=extra,
    )


def parse_columns(text: str | None) -> dict[str, str]:
    """Parse ``"time_s=t,torque_nm=tau"`` into ``{"time_s": "t", "torque_nm": "tau"}``.

    Raises
    ------
    ValueError
        Malformed item or an unknown canonical name.
    """
    if not text:
        return {}
    out: dict[str, str] = {}
    valid = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        if "=" not in item:
            raise ValueError(f"--columns item {item!r} must look like canonical=file_column, e.g. time_s=t")
        a, b = (s.strip() for s in item.split("=", 1))
        if a not in valid:
            raise ValueError(f"--columns: unknown canonical column {a!r}; valid: {', '.join(valid)}")
        out[a] = b
    return out


def load_csv(path: str | Path, columns: dict[str, str] | None = None, linear: bool = False) -> Record:
    """Load a CSV record with a header row.

    Parameters
    ----------
    path : str or Path
    columns : dict, optional
        Canonical name -> name in the file (``time_s``, ``torque_nm``, ``position_rad``,
        ``velocity_rad_s``, ``current_a``).
    linear : bool
        Position in m and force in N.

    Raises
    ------
    RecordError
        Missing file or column, non-numeric cell, non-uniform time; the message names the file,
        the column (and row) and what was expected.
    """
    path = Path(path)
    columns = dict(columns or {})
    if not path.exists():
        raise RecordError(f"{path}: no such file")
    fast = _load_csv_fast(path, columns, linear)
    if fast is not None:
        return fast
    with path.open(newline="") as fh:
        lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise RecordError(f"{path}: empty file; expected a header row with {', '.join(REQUIRED_COLUMNS)}")
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader)]
    rows = list(reader)
    index = {h: i for i, h in enumerate(header)}
    data: dict[str, np.ndarray] = {}
    for canon in REQUIRED_COLUMNS + OPTIONAL_COLUMNS:
        name = columns.get(canon, canon)
        if name not in index:
            if canon in REQUIRED_COLUMNS:
                hint = f" (mapped from {canon!r} by --columns)" if canon in columns else ""
                raise RecordError(
                    f"{path}: column {name!r}{hint} not found; expected a header with "
                    f"{', '.join(REQUIRED_COLUMNS)} (map other names with --columns canonical=name); "
                    f"header has {header}"
                )
            continue
        j = index[name]
        vals = np.empty(len(rows))
        for r, row in enumerate(rows):
            try:
                vals[r] = float(row[j])
            except (ValueError, IndexError):
                cell = row[j] if j < len(row) else "<missing>"
                raise RecordError(
                    f"{path}: column {name!r}, row {r + 2}: expected a number, got {cell!r}"
                ) from None
        if not np.all(np.isfinite(vals)):
            r = int(np.argmax(~np.isfinite(vals)))
            raise RecordError(f"{path}: column {name!r}, row {r + 2}: expected a finite number")
        data[canon] = vals
    _check_uniform(path, data["time_s"])
    return Record(
        name=path.stem,
        t_s=data["time_s"],
        position=data["position_rad"],
        torque=data["torque_nm"],
        velocity=data.get("velocity_rad_s"),
        current_a=data.get("current_a"),
        linear=linear,
        source=str(path),
        extra={"format": "csv"},
    )


def _load_csv_fast(path: Path, columns: dict[str, str], linear: bool) -> Record | None:
    """Numeric CSV through ``numpy.loadtxt`` (compiled parser; ≈ 40 B per value in memory instead of
    the Python row lists). Returns None whenever anything is unusual (comments, blank lines, a bad
    cell, a missing column): the careful reader then produces the exact error message."""
    try:
        with path.open() as fh:
            header = [h.strip() for h in fh.readline().split(",")]
        index = {h: i for i, h in enumerate(header)}
        want = {c: columns.get(c, c) for c in REQUIRED_COLUMNS + OPTIONAL_COLUMNS}
        if any(want[c] not in index for c in REQUIRED_COLUMNS):
            return None
        use = {c: index[n] for c, n in want.items() if n in index}
        order = sorted(set(use.values()))
        arr = np.loadtxt(path, delimiter=",", skiprows=1, usecols=order, ndmin=2, dtype=float)
    except (ValueError, OSError, UnicodeDecodeError):
        return None
    if arr.shape[0] == 0 or not np.all(np.isfinite(arr)):
        return None
    col = {c: arr[:, order.index(j)].copy() for c, j in use.items()}
    del arr
    _check_uniform(path, col["time_s"])
    return Record(name=path.stem, t_s=col["time_s"], position=col["position_rad"], torque=col["torque_nm"],
                  velocity=col.get("velocity_rad_s"), current_a=col.get("current_a"), linear=linear, source=str(path),
                  extra={"format": "csv"})


SENSOR_LOG_MAGIC = "# schmidt-fil sensor log"


def load_sensor_log(path: str | Path, axis: str = "ra", parameter_file: str | Path | None = None) -> Record:
    """Load the sensor-data log that ``schmidt-fil run`` writes (``sensor.log``) as a record.

    The drive torque at the axis is what the operator can compute from the logged shunt
    currents: ``N·K·(i_a − i_b)`` (motor A pushes +, motor B pushes −; gear losses and rotor
    inertia neglected), with K and N from the plant parameter file (default: the packaged one,
    i.e. the constants the emulator used unless the scenario overrode them). Position is the
    QEI count × 2π / (counts per rev × roller ratio). Resolution is the telescope's: 10-bit
    shunt ADC (≈ 49 mA, ≈ 6 N·m at the axis) and 0.01148″ per count.

    Raises
    ------
    RecordError
        Not a sensor log, unknown axis, or too few rows.
    """
    from plant.params import load_parameters

    path = Path(path)
    lines = path.read_text(encoding="ascii", errors="replace").splitlines()
    if not lines or not lines[0].startswith(SENSOR_LOG_MAGIC):
        raise RecordError(f"{path}: not a schmidt-fil sensor log (first line must start with {SENSOR_LOG_MAGIC!r})")
    header = next((l[1:].split() for l in lines[1:3] if l.startswith("# t_s")), None)
    if header is None:
        raise RecordError(f"{path}: no '# t_s ...' column header")
    need = [f"{axis}_qei_counts", f"{axis}_current_a_a", f"{axis}_current_b_a"]
    missing = [c for c in need if c not in header]
    if missing:
        raise RecordError(f"{path}: axis {axis!r}: missing columns {missing}; expected axis 'ra' or 'dec'")
    idx = [header.index(c) for c in ["t_s"] + need]
    rows = [l.split() for l in lines if l and not l.startswith("#")]
    if len(rows) < 50:
        raise RecordError(f"{path}: {len(rows)} rows; a calibration needs at least 50")
    data = np.array([[float(r[i]) for i in idx] for r in rows])
    ap = load_parameters(parameter_file).axes[axis]
    k, n = ap.motor.torque_constant_nm_a, ap.gear.ratio
    counts_per_rev = ap.encoders.incremental_counts_per_rev * ap.encoders.roller_ratio
    t = data[:, 0]
    _check_uniform(path, t)
    return Record(
        name=f"{path.parent.name}/{path.name}:{axis}",
        t_s=t - t[0],
        position=data[:, 1] * 2.0 * np.pi / counts_per_rev,
        torque=n * k * (data[:, 2] - data[:, 3]),
        current_a=data[:, 2] - data[:, 3],
        linear=False,
        source=str(path),
        extra={"format": "sensor_log", "axis": axis, "torque_constant_nm_a": k, "gear_ratio": n},
    )


def load_record(path: str | Path, columns: dict[str, str] | None = None, linear: bool = False,
                axis: str = "ra") -> Record:
    """Load a record: ``.mat`` → :func:`load_emps`; a schmidt-fil ``sensor.log`` →
    :func:`load_sensor_log` (``axis`` selects RA or DEC); anything else → :func:`load_csv`."""
    path = Path(path)
    if path.suffix.lower() == ".mat":
        return load_emps(path)
    try:
        with path.open("r", encoding="ascii", errors="replace") as f:
            first = f.readline()
    except OSError as exc:
        raise RecordError(f"{path}: cannot read: {exc.strerror}") from None
    if first.startswith(SENSOR_LOG_MAGIC):
        return load_sensor_log(path, axis=axis)
    return load_csv(path, columns=columns, linear=linear)


def write_csv(record: Record, path: str | Path) -> Path:
    """Write a record as CSV with the canonical header (``time_s, torque_nm, position_rad`` …)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = {"time_s": record.t_s, "torque_nm": record.torque, "position_rad": record.position}
    if record.velocity is not None:
        cols["velocity_rad_s"] = record.velocity
    if record.current_a is not None:
        cols["current_a"] = record.current_a
    arr = np.column_stack(list(cols.values()))
    np.savetxt(path, arr, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
    return path
