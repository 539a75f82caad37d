"""The maintenance quantities of paper §5.2, from the frames the host received (issue 12).

"In the second console, the individual motor currents and the tachometer signals can be
monitored. The tachometer readings and the telescope velocity measurements are used for
displaying the gear reduction in runtime and logged for analysing the backlash in the gear
boxes. Also the auxiliary position encoder readings and its difference from the on-shaft encoder
readings are displayed."

Everything here is computed from what :class:`host.client.HostClient` decoded (``TACH_STATUS``,
``AUX_POSITION``, ``AXIS_STATUS``, ``AXIS_AUX``, ``POSITION``), never from the plant:

* **motor speed** [rad/s]: the tachometer board's own estimate (``TACH_STATUS`` speed).
* **runtime gear reduction** per motor: motor turns / axis turns over the last
  :data:`GEAR_WINDOW_US` (1 s) of the host's 10 ms samples: Δ(motor encoder counts) /
  counts_per_rev ÷ Δ(axis QEI counts from ``AXIS_STATUS``) / axis counts_per_rev, both
  resolutions read from the boards that ran. Not defined (``nan`` in the log, None in the report)
  while the axis moved less than :data:`MIN_AXIS_COUNTS` (11.5″) in the window or the motor less
  than :data:`MIN_MOTOR_COUNTS`. Its resolution is one motor count in the window: 0.8 ‰ of the
  reading at the 2°/s slew, ≈6 % at 15″/s tracking (17 motor counts per second with the
  parameter file's 4000 counts/rev); per segment the report also gives the reduction over the
  whole settled segment, which resolves tracking to a few per mille.
* **auxiliary − main encoder** [arcsec]: the auxiliary encoder's angle minus the main EnDat
  encoder's last valid ``POSITION`` (:meth:`host.client.HostClient.main_arcsec`), for every
  ``AUX_POSITION`` whose turn count is known (flag ``turns_unknown`` clear). The frames carry no
  sampling time, so during a slew the two boards' sampling skew shows up (up to rate × 10 ms);
  the report's statistics therefore use only frames while the main encoder moves at most
  ``HostClient.AUX_COMPARE_MAX_RATE_ARCSEC_S`` (100″/s: skew ≤ 1″); ``sensor.log`` has every one.
* **axis rate of the velocity reader** [arcsec/s] (``full`` network): the friction-roller
  encoder's node's own estimate (``AXIS_VELOCITY``), beside the axis controller's QEI rate.
* **motor currents**: the ``AXIS_AUX`` shunt ADC counts (already in ``sensor.log``); the report adds
  each motor's peak.
"""

from __future__ import annotations

import math
from array import array
from bisect import bisect_left, bisect_right
from collections import deque

from boards.registry import BOARDS
from bus.units import ARCSEC_PER_REV

__all__ = ["GEAR_WINDOW_US", "MIN_AXIS_COUNTS", "MIN_MOTOR_COUNTS", "Maintenance", "sensor_columns"]

#: Window of the runtime gear reduction [µs] (assumed: a console refresh a person can read).
GEAR_WINDOW_US = 1_000_000
#: Least axis motion in the window for a gear reduction [axis QEI counts] (1000 × 0.0115″ = 11.5″).
MIN_AXIS_COUNTS = 1000
#: Least motor motion in the window for a gear reduction [motor encoder counts].
MIN_MOTOR_COUNTS = 4


def _tachs(board_names) -> list[tuple[str, str, int]]:
    """(axis, motor, node) of the tachometers among ``board_names`` (node order)."""
    return [(i.axis, i.motor, int(i.node_id)) for n in board_names
            for s, i in (BOARDS[n],) if s.kind == "tachometer"]


def _auxes(board_names) -> list[str]:
    """Axes of the auxiliary encoders among ``board_names``."""
    return [i.axis for n in board_names for s, i in (BOARDS[n],) if s.kind == "aux_encoder"]


def _velocity_axes(board_names) -> list[str]:
    """Axes of the axis velocity readers among ``board_names``."""
    return [i.axis for n in board_names for s, i in (BOARDS[n],) if s.kind == "velocity_reader"]


def sensor_columns(board_names) -> tuple[str, ...]:
    """The ``sensor.log`` columns the maintenance quantities add for a network of
    ``board_names`` (none for a network without tachometers or auxiliary encoders, e.g. basic)."""
    cols = []
    for axis, motor, _ in _tachs(board_names):
        cols += [f"{axis}_motor_{motor}_speed_rad_s", f"{axis}_gear_reduction_{motor}"]
    for axis in _auxes(board_names):
        cols += [f"{axis}_aux_pos_arcsec", f"{axis}_aux_minus_main_arcsec"]
    for axis in _velocity_axes(board_names):
        cols.append(f"{axis}_velocity_node_arcsec_s")
    return tuple(cols)


class Maintenance:
    """Runtime maintenance quantities of one session (sampled with the host's 10 ms samples).

    Parameters
    ----------
    client : host.client.HostClient
        The host whose decoded frames are used.
    board_names : sequence of str
        The boards of the network (which tachometers and auxiliary encoders exist).
    """

    def __init__(self, client, board_names) -> None:
        self.client = client
        self.tachs = _tachs(board_names)
        self.auxes = _auxes(board_names)
        self.velocity_axes = _velocity_axes(board_names)
        self.columns = sensor_columns(board_names)
        self._hist: deque = deque()     # (t_us, {axis: axis counts}, {node: motor counts}), 1 s
        # every sample once every tachometer has reported (segment reductions): compact int64
        # columns, 8 bytes per value (a one-hour run on the full network: ≈ 20 MB)
        self._t = array("q")
        self._axis_cols = {a: array("q") for a in dict.fromkeys(a for a, _, _ in self.tachs)}
        self._node_cols = {n: array("q") for _, _, n in self.tachs}
        self.last_reduction: dict[int, float | None] = {n: None for _, _, n in self.tachs}

    def _axis_counts_per_rev(self, axis: str) -> float:
        return ARCSEC_PER_REV / self.client.arcsec_per_count[axis]

    def sample(self, now_us: int) -> tuple:
        """Update the windows with the host's state now; return the ``sensor.log`` values in the
        order of :attr:`columns` (``nan`` where a quantity is undefined)."""
        c = self.client
        axes = {a for a, _, _ in self.tachs}
        snap = (now_us, {a: c.axes[a].counts for a in axes},
                {n: c.tachs[n].counts for _, _, n in self.tachs if n in c.tachs and c.tachs[n].t_us >= 0})
        if len(snap[2]) == len(self._node_cols):
            self._t.append(now_us)
            for a, col in self._axis_cols.items():
                col.append(snap[1][a])
            for n, col in self._node_cols.items():
                col.append(snap[2][n])
        h = self._hist
        h.append(snap)
        while h and now_us - h[0][0] > GEAR_WINDOW_US:
            h.popleft()
        out: list = []
        for axis, motor, node in self.tachs:
            st = c.tachs.get(node)
            r = self.reduction(h[0], snap, axis, node) if len(h) > 1 else None
            self.last_reduction[node] = r
            out += [st.speed_rad_s if st is not None and st.t_us >= 0 else math.nan,
                    math.nan if r is None else r]
        for axis in self.auxes:
            st = c.aux.get(axis)
            ok = st is not None and st.t_us >= 0
            out += [st.angle_arcsec if ok else math.nan,
                    st.diff_arcsec if ok and st.diff_arcsec is not None else math.nan]
        for axis in self.velocity_axes:
            st = c.axis_velocity.get(axis)
            out.append(st.rate_arcsec_s if st is not None and st.t_us >= 0 else math.nan)
        return tuple(out)

    def reduction(self, a: tuple, b: tuple, axis: str, node: int) -> float | None:
        """Gear reduction of tachometer ``node`` between snapshots ``a`` and ``b``: motor turns
        per axis turn, None when the motion is below :data:`MIN_AXIS_COUNTS` /
        :data:`MIN_MOTOR_COUNTS` or a count is missing."""
        if node not in a[2] or node not in b[2]:
            return None
        da = b[1][axis] - a[1][axis]
        dm = b[2][node] - a[2][node]
        if abs(da) < MIN_AXIS_COUNTS or abs(dm) < MIN_MOTOR_COUNTS:
            return None
        cpr = self.client.tach_counts_per_rev[node]
        return (dm / cpr) / (da / self._axis_counts_per_rev(axis))

    def segment_reduction(self, t0_us: int, t1_us: int, axes=("ra", "dec")) -> dict:
        """``{"<axis>_<motor>": reduction or None}`` of the motors of ``axes`` over the host
        samples in [t0, t1] (first to last sample): the whole span, so slow motion is resolved."""
        i0, i1 = bisect_left(self._t, t0_us), bisect_right(self._t, t1_us) - 1

        def snap(i):
            return (self._t[i], {a: c[i] for a, c in self._axis_cols.items()},
                    {n: c[i] for n, c in self._node_cols.items()})

        out = {}
        for axis, motor, node in self.tachs:
            if axis not in axes:
                continue
            r = self.reduction(snap(i0), snap(i1), axis, node) if i1 > i0 else None
            out[f"{axis}_{motor}"] = None if r is None else round(r, 4)
        return out

    def summary(self, nominal_reduction: dict) -> dict:
        """The report's ``maintenance`` section (without per-segment rows).

        Parameters
        ----------
        nominal_reduction : dict
            ``{axis: gear ratio of the plant that ran}`` for comparison.
        """
        c = self.client
        motors = {}
        for axis, motor, node in self.tachs:
            st = c.tachs.get(node)
            motors[f"{axis}_{motor}"] = {
                "node": node, "frames": st.frames if st else 0,
                "counts_per_rev": c.tach_counts_per_rev.get(node),
                "last_speed_rad_s": round(st.speed_rad_s, 6) if st else None,
                "peak_current_a": round(c.peak_current_a.get((axis, motor), 0.0), 3),
            }
        aux = {}
        for axis in self.auxes:
            st = c.aux.get(axis)
            if st is None or st.n == 0:
                aux[axis] = {"frames": st.frames if st else 0, "compared": 0}
                continue
            mean = st.sum / st.n
            aux[axis] = {"frames": st.frames, "compared": st.n, "mean_arcsec": round(mean, 3),
                         "rms_arcsec": round(math.sqrt(st.sumsq / st.n), 3),
                         "max_abs_arcsec": round(st.max_abs, 3)}
        return {"gear_window_s": GEAR_WINDOW_US / 1e6,
                "aux_compare_max_rate_arcsec_s": c.AUX_COMPARE_MAX_RATE_ARCSEC_S, "nominal_gear_reduction": nominal_reduction,
                "motors": motors, "aux_minus_main_arcsec": aux}
