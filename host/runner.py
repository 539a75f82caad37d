"""Run a scenario against the emulated telescope network and measure how well it tracked.

The runner is the operator: it powers the network on (health check), sends each segment's
command through the host client over CAN, advances simulated time, samples what the host sees
(status frames) plus the plant truth every 10 ms, and finally computes the report.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from bus.errors import HostTimeout
from host.report import MEASUREMENT_METHOD, AxisTrace, plot_axes, segment_metrics, write_reports
from host.realtime import SIM_STEP_US
from host.scenario import Scenario, ScenarioError
from host.session import SAMPLE_PERIOD_US, SAMPLE_PHASE_US, Session, sensor_row  # noqa: F401  (re-exported)

__all__ = ["RunResult", "run_scenario", "sensor_row", "SAMPLE_PERIOD_US", "SAMPLE_PHASE_US"]

#: Simulated time between progress updates [µs] (the simulated clock's step).
CHUNK_US = SIM_STEP_US


@dataclass
class _Recorder:
    t_us: list = field(default_factory=list)
    cols: dict = field(default_factory=dict)

    def add(self, axis: str, **vals) -> None:
        d = self.cols.setdefault(axis, {})
        for k, v in vals.items():
            d.setdefault(k, []).append(v)

    def trace(self, axis: str, arcsec_per_count: float) -> AxisTrace:
        d = {k: np.asarray(v) for k, v in self.cols[axis].items()}
        return AxisTrace(
            t_s=np.asarray(self.t_us, dtype=np.int64) / 1e6,
            counts=d["counts"].astype(float),
            u=d["u"].astype(float),
            mode=d["mode"].astype(int),
            setpoint_arcsec_s=d["setpoint"].astype(float),
            current_a_a=d["ia"].astype(float),
            current_b_a=d["ib"].astype(float),
            truth_angle_rad=d["truth"].astype(float),
            arcsec_per_count=arcsec_per_count,
            tick_rate_arcsec_s=d["tick_rate"].astype(float),
        )


@dataclass
class RunResult:
    """What a run produced: the report dict and the files written."""

    report: dict
    files: list[Path]


def run_scenario(
    scenario: Scenario,
    out_dir: Path | None,
    progress: Callable[[float, float], None] | None = None,
    plots: bool = True,
    boards=None,
) -> RunResult:
    """Build the network of ``scenario``, run every segment and write logs and reports.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario (see :func:`host.scenario.load_scenario`).
    out_dir : Path, str or None
        Where the four logs, ``report.json``, ``report.md`` and PNG plots go, plus
        ``telemetry.log`` (RS232 packets, one line per 10 ms sample) when ``rs232.enabled``.
        ``None`` keeps everything in memory (tests, benchmarks) and writes no files.
    progress : callable(done_s, total_s), optional
        Called every 0.2 simulated seconds.
    plots : bool
        Write PNG plots (needs ``out_dir``).
    boards : iterable of str, optional
        Registry names of the boards to build (default: today's five,
        :data:`boards.registry.DEFAULT_BOARD_NAMES`); e.g. add ``"display"``, ``"dome"``,
        ``"weather"`` for the room nodes of issue 12 (``display.log`` is then written).

    Returns
    -------
    RunResult

    Raises
    ------
    HostTimeout
        A board did not answer the power-on health check (the report names it).
    SimulationError
        A board or plant raised; the message names the board and the simulated time. The logs
        written up to that point are kept.
    """
    out_dir = Path(out_dir) if out_dir is not None else None
    build = None
    if boards is not None:
        from host.network import build_network

        def build(sc, host_cls):
            return build_network(sc, host_cls=host_cls, boards=boards)
    session = Session(scenario, out_dir, header=f"scenario {scenario.name}; seed {scenario.seed}", build=build)
    tel, client, sched, logs = session.tel, session.client, session.scheduler, session.logs
    rec = _Recorder()
    setpoints = client.setpoints

    def record(now_us: int) -> None:
        rec.t_us.append(now_us)
        for axis in ("ra", "dec"):
            st = client.axes[axis]
            rec.add(axis, counts=st.counts, u=st.u, mode=st.mode, setpoint=setpoints[axis],
                    ia=st.current_a_a, ib=st.current_b_a, truth=tel.plants[axis].axis_angle_rad,
                    tick_rate=st.rate_arcsec_s)  # firmware's last per-tick rate (AXIS_AUX qei_delta)

    seg_spans: list[dict] = []
    total_us = int(round(scenario.duration_s * 1e6)) + client.BOOT_US + client.POWER_ON_US
    paced = session.paced
    # on a real bus simulated time must not outrun the wall clock, from power-on on (the health
    # check's answer window is wall-clock time for nodes outside this process): the session's clock
    client.advance = lambda t_us: session.advance(t_us)

    def show_progress() -> None:
        if progress and (not paced or sched.now_us % CHUNK_US < session.clock.step_us):
            progress(sched.now_us / 1e6, total_us / 1e6)

    try:
        for i, seg in enumerate(scenario.segments):     # before anything runs
            if seg.dome is not None and "dome" not in tel.boards:
                raise ScenarioError(scenario.source_path, None, f"segments[{i}].dome",
                                    "the network has no dome board")
        healthy = client.power_on()
        if not healthy.ok:
            raise HostTimeout(
                "power-on health check failed: no answer from " + ", ".join(healthy.missing)
                + f" within {client.POWER_ON_US // 1000} ms"
            )
        session.schedule_faults()
        session.start_sampling("host-recorder", record)
        for seg in scenario.segments:
            t0 = sched.now_us
            axes = ("ra", "dec") if seg.axis == "both" else (seg.axis,)
            for axis in axes:
                client.command_axis(axis, seg.mode, seg.direction, seg.rate_arcsec_s)
            if seg.focus_halfsteps is not None:
                client.command_focus_move_to(seg.focus_halfsteps)
            if seg.dome is not None:
                client.command_dome(seg.dome)
            t_end = t0 + int(round(seg.duration_s * 1e6))
            session.advance(t_end, on_step=show_progress)
            seg_spans.append({"seg": seg, "axes": axes, "t0_us": t0, "t1_us": t_end,
                              "setpoints": {a: setpoints[a] for a in axes}})
    except HostTimeout as exc:
        if logs:
            logs.error(sched.now_us, "host", "health-check", str(exc))
        raise
    finally:
        session.close()

    window_ms = scenario.report.velocity_window_ms
    # the encoder resolution of the axis boards that ran (the parameter file's encoder)
    traces = {axis: rec.trace(axis, client.arcsec_per_count[axis]) for axis in ("ra", "dec")} if rec.t_us else {}
    segments = []
    rated = tel.params.axes["ra"].motor.rated_current_a
    for span in seg_spans:
        seg = span["seg"]
        for axis in span["axes"]:
            sp = span["setpoints"][axis]
            entry = {
                "name": seg.name if len(span["axes"]) == 1 else f"{seg.name}/{axis}",
                "axis": axis,
                "mode": seg.mode,
                "direction": seg.direction,
                "setpoint_arcsec_s": round(sp, 4),
                "t0_s": span["t0_us"] / 1e6,
                "t1_s": span["t1_us"] / 1e6,
                "settle_s": seg.settle_s,
            }
            if session.maintenance is not None and session.maintenance.tachs:   # issue 12, §5.2
                entry["gear_reduction"] = session.maintenance.segment_reduction(
                    span["t0_us"] + int(round(seg.settle_s * 1e6)), span["t1_us"], (axis,))
            if sp != 0.0 and seg.mode != "stop":
                entry.update(segment_metrics(traces[axis], entry["t0_s"] + seg.settle_s, entry["t1_s"], sp,
                                             window_ms, rated))
            else:
                entry.update({"peak_error_pct": None, "rms_error_pct": None, "limit_cycle": False})
            segments.append(entry)
    wall_s = time.perf_counter() - session.wall0
    report = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": scenario.seed,
        "bus": scenario.bus.model_dump(),
        "network": tel.network_name,                  # issue 12: the boards that ran
        "nodes": {name: b.node_id for name, b in tel.boards.items()},
        "simulated_s": sched.now_us / 1e6,
        "wall_s": round(wall_s, 3),
        "method": MEASUREMENT_METHOD,
        "velocity_window_ms": window_ms,
        "segments": segments,
        "controller": tel.controller_summary(),
        "plant": tel.plant_summary(),
        "gear_lines": {axis: p.gear_lines for axis, p in tel.plants.items()},  # issue 9: lines that ran
        "bus_stats": tel.bus_stats(),
        "boards": {name: {**row, "identity": client.identities.get(name),
                          "parameters": client.parameters.get(name)}
                   for name, row in tel.board_summary().items()},
        "rs232": tel.rs232_summary(),
        "room": tel.room_summary(),              # issue 12: dome, weather, display (None without them)
        "weather_stops": client.weather_stops, "host_refused_commands": client.refused_commands,
        "errors": session.errors + client.error_lines(),
        "realtime": session.clock_stats(),
    }
    if session.maintenance is not None:                # issue 12: §5.2 maintenance quantities
        report["maintenance"] = session.maintenance.summary(
            {axis: round(p.params.gear.ratio, 4) for axis, p in tel.plants.items()})
    files: list[Path] = []
    if out_dir is not None:
        files += session.files()
        files += list(write_reports(out_dir, report))
        if plots and traces:
            files += plot_axes(out_dir, traces, segments, window_ms)
    return RunResult(report=report, files=files)

