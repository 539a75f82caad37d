"""Gear-train disturbance: torque lines at the orders of the RA/DEC gear trains (paper §2.2, §4).

The paper names "disturbances due to imbalances in the gears" (§4) as one cause of the velocity
oscillations it measured. Their *frequencies* follow from the gear train alone (paper §2.2:
stages 27:113, 21:123, 17:250 between each motor and the axis; friction roller 735:30): each
rotating part or tooth mesh repeats a fixed number of times per axis revolution (its *order*).
Their *amplitudes* are not in the paper; each sits in the parameter file with its source, and an
amplitude nobody can source is 0 (``plant/parameters.yaml``, ``axes.<axis>.gear_disturbance``).

Model
-----
Every line is a torque on the axis, added to the load (positive opposes positive motion, as
:mod:`plant.effects`)::

    T = A · sin(order · angle + phase)

* ``angle`` is the axis angle θ for the axis-level lines (``axis_once``, ``axis_twice``,
  ``roller_once``) and, for the lines of one motor train, that train's motor angle reflected to
  the axis (φk / N). Each train has its own line (same amplitude, its own phase): the two trains
  are identical gearboxes (§2.2) but their gears do not turn in step (the backlash offset).
* ``A`` is **load independent** (N·m at the axis, a geometric mesh / eccentricity error). A ripple
  scaled with the friction torque would make low-preload tracking stick-slip, contradicting
  Fig. 13b (see issue 9); load dependence would need data nobody has.
* Phases are **fixed** in the parameter file (default 0, "assumed: no data"); they do not change
  with the seed, so a run is reproducible from the file alone.

The lines are evaluated inside the integrator kernel at each substep's midpoint
(:func:`plant.kernel.gear_lines_torque_nm`), the same place and time as the other additive load
torques. With no line of non-zero amplitude the kernel receives an empty table and the plant is
bit-identical to a plant without this model.

Orders (cycles per axis revolution), from the tooth counts of §2.2:

============== ====== ===================================================
line           order  what
============== ====== ===================================================
axis_once      1      bull gear / axis eccentricity
axis_twice     2      bull gear ovality
roller_once    24.5   encoder friction roller (735:30)
stage3_mesh    250    17:250 mesh (bull gear teeth), per train
shaft2_once    14.71  shaft 2 (17 / 123) once per rev, per train
stage2_mesh    1808.8 21:123 mesh, per train
shaft1_once    86.13  shaft 1 (21 / 113) once per rev, per train
motor_once     360.49 motor shaft (27-tooth pinion) once per rev, per train
motor_twice    720.98 motor shaft twice per rev, per train
stage1_mesh    9733.2 27:113 mesh (27 teeth per motor rev), per train
============== ====== ===================================================
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from bus.units import ARCSEC_PER_REV

__all__ = [
    "STAGES",
    "ROLLER_RATIO",
    "LINE_ORDERS",
    "AXIS_LINES",
    "TRAIN_LINES",
    "line_orders",
    "parse_section",
    "lines_table",
    "line_rows",
    "line_frequency_hz",
    "SOURCE_AXIS",
    "SOURCE_TRAIN_A",
    "SOURCE_TRAIN_B",
]

#: Gear stages motor → axis as (pinion teeth, gear teeth) (paper §2.2).
STAGES = ((27, 113), (21, 123), (17, 250))
#: Encoder friction roller: encoder revolutions per axis revolution (paper §2.2, 735:30).
ROLLER_RATIO = 735.0 / 30.0

#: Codes of the angle a line follows (column 0 of :func:`lines_table`).
SOURCE_AXIS, SOURCE_TRAIN_A, SOURCE_TRAIN_B = 0.0, 1.0, 2.0


def line_orders() -> dict[str, float]:
    """Order (cycles per axis revolution) of every line, from the tooth counts of §2.2.

    Returns
    -------
    dict of str to float
        Keyed by line name, in the order of the module table.
    """
    (z1p, z1g), (z2p, z2g), (z3p, z3g) = STAGES
    shaft2 = z3g / z3p                 # revs of shaft 2 per axis rev (14.71)
    shaft1 = shaft2 * z2g / z2p        # shaft 1 (86.13)
    motor = shaft1 * z1g / z1p         # motor (360.49 = the gear ratio)
    return {
        "axis_once": 1.0,
        "axis_twice": 2.0,
        "roller_once": ROLLER_RATIO,
        "stage3_mesh": float(z3g),
        "shaft2_once": shaft2,
        "stage2_mesh": shaft2 * z2g,
        "shaft1_once": shaft1,
        "motor_once": motor,
        "motor_twice": 2.0 * motor,
        "stage1_mesh": motor * z1p,
    }


#: Orders of every line, cycles per axis revolution.
LINE_ORDERS = line_orders()
#: Lines that follow the axis angle (one per axis).
AXIS_LINES = ("axis_once", "axis_twice", "roller_once")
#: Lines that follow a motor train (one per train, two per axis).
TRAIN_LINES = ("stage3_mesh", "shaft2_once", "stage2_mesh", "shaft1_once", "motor_once", "motor_twice",
               "stage1_mesh")


def line_frequency_hz(name_or_order, rate_arcsec_s: float) -> float:
    """Frequency of a line at a steady axis rate [Hz].

    Parameters
    ----------
    name_or_order : str or float
        Line name (see :data:`LINE_ORDERS`) or an order [cycles per axis revolution].
    rate_arcsec_s : float
        Axis rate [″/s] (sign ignored).

    Returns
    -------
    float
        order × |rate| / 1 296 000″.
    """
    order = LINE_ORDERS[name_or_order] if isinstance(name_or_order, str) else float(name_or_order)
    return order * abs(rate_arcsec_s) / ARCSEC_PER_REV


def _leaf_value(node: Any, path: str) -> float:
    if not (isinstance(node, dict) and "value" in node):
        raise ValueError(f"{path}: expected a leaf {{value, unit, source}}")
    v = node["value"]
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            raise ValueError(f"{path}: expected a number, got {v!r}") from None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{path}: expected a finite number, got {v!r}")
    return float(v)


def parse_section(node: Mapping | None, path: str) -> dict:
    """Validate an ``axes.<axis>.gear_disturbance`` section of the parameter file.

    Parameters
    ----------
    node : mapping or None
        The section as read from YAML; ``None`` (section absent, e.g. an older calibrated file)
        means no lines.
    path : str
        Dotted path used in error messages (``axes.ra.gear_disturbance``).

    Returns
    -------
    dict
        ``{line: {"amplitude_nm": A, "phase_rad": φ}}`` for axis lines and ``{line:
        {"amplitude_nm": A, "phase_a_rad": φa, "phase_b_rad": φb}}`` for train lines (plain floats;
        keys as in the file, so :func:`plant.params.dump_parameters` can write them back).

    Raises
    ------
    ValueError
        Unknown line or key, a missing key, a negative amplitude or a non-number (names the path).
    """
    if node is None:
        return {}
    if not isinstance(node, dict):
        raise ValueError(f"{path}: expected a mapping of line names ({', '.join(LINE_ORDERS)})")
    out = {}
    for name, spec in node.items():
        if name not in LINE_ORDERS:
            raise ValueError(f"{path}.{name}: unknown gear line; valid: {', '.join(LINE_ORDERS)}")
        keys = ("amplitude_nm", "phase_rad") if name in AXIS_LINES else ("amplitude_nm", "phase_a_rad", "phase_b_rad")
        if not isinstance(spec, dict):
            raise ValueError(f"{path}.{name}: expected a mapping with keys {', '.join(keys)}")
        extra = sorted(set(spec) - set(keys))
        missing = [k for k in keys if k not in spec]
        if extra or missing:
            raise ValueError(f"{path}.{name}: expected keys {', '.join(keys)}"
                             + (f"; unknown {extra}" if extra else "") + (f"; missing {missing}" if missing else ""))
        vals = {k: _leaf_value(spec[k], f"{path}.{name}.{k}") for k in keys}
        if vals["amplitude_nm"] < 0.0:
            raise ValueError(f"{path}.{name}.amplitude_nm: must be >= 0 (the phase carries the sign), "
                             f"got {vals['amplitude_nm']}")
        out[name] = vals
    return out


def line_rows(section: Mapping | None) -> list[dict]:
    """The lines of non-zero amplitude, one dict per row of :func:`lines_table` (same order).

    Returns
    -------
    list of dict
        ``line``, ``follows`` (``"axis"``, ``"train_a"``, ``"train_b"``), ``order``,
        ``amplitude_nm``, ``phase_rad``.
    """
    rows = []
    for name, v in (section or {}).items():
        a = float(v["amplitude_nm"])
        if a == 0.0:
            continue
        order = LINE_ORDERS[name]
        if name in AXIS_LINES:
            rows.append({"line": name, "follows": "axis", "order": order, "amplitude_nm": a,
                         "phase_rad": float(v["phase_rad"])})
        else:
            for train in ("a", "b"):
                rows.append({"line": name, "follows": f"train_{train}", "order": order, "amplitude_nm": a,
                             "phase_rad": float(v[f"phase_{train}_rad"])})
    return rows


def lines_table(section: Mapping | None) -> np.ndarray:
    """The kernel's line table for one axis: one row per line of non-zero amplitude.

    Parameters
    ----------
    section : mapping or None
        :func:`parse_section` output (``AxisParameters.gear_disturbance``).

    Returns
    -------
    ndarray, shape (n, 4), float64, C-contiguous
        Columns: angle source (:data:`SOURCE_AXIS`, :data:`SOURCE_TRAIN_A`,
        :data:`SOURCE_TRAIN_B`), order [cycles per axis rev], amplitude [N·m at the axis], phase
        [rad]. Empty (shape (0, 4)) when every amplitude is 0.
    """
    code = {"axis": SOURCE_AXIS, "train_a": SOURCE_TRAIN_A, "train_b": SOURCE_TRAIN_B}
    rows = [(code[r["follows"]], r["order"], r["amplitude_nm"], r["phase_rad"]) for r in line_rows(section)]
    return np.ascontiguousarray(np.array(rows, dtype=np.float64).reshape(-1, 4))
