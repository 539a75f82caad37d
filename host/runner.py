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

from bus.errors import HostTimeout, SimulationError
from bus.scheduler import PRIO_HOST
from host.logs import CANDUMP_LOG, CandumpWriter, HostLogs
from host.report import MEASUREMENT_METHOD, AxisTrace, plot_axes, segment_metrics, write_reports
from host.rs232 import TELEMETRY_LOG
from host.scenario import Scenario

__all__ = ["RunResult", "run_scenario", "sensor_row", "schedule_faults", "SAMPLE_PERIOD_US", "SAMPLE_PHASE_US"]

#: Host sampling period of the status data [µs]: the axis controllers publish every 10 ms (paper
#: §3.4: 10 ms samples).
SAMPLE_PERIOD_US = 10_000
#: Phase of the host sampling within the 10 ms period [µs], so each sample holds the latest frame.
SAMPLE_PHASE_US = 5_000
#: Simulated time between progress updates [µs].
CHUNK_US = 200_000


@dataclass
class _Recorder:
    t_us: list = field(default_factory=list)
    cols: dict = field(default_factory=dict)

    def add(self, axis: str, **vals) -> None:
        d = self.cols.setdefault(axis, {})
        for k, v in vals.items():
            d.setdefault(k, []).append(v)

    def trace(self, axis: str) -> AxisTrace:
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
    from host.network import build_network

    wall0 = time.perf_counter()
    out_dir = Path(out_dir) if out_dir is not None else None
    # the output directory first: if it cannot be created nothing has been built to tear down
    logs = HostLogs(out_dir, header=f"scenario {scenario.name}; seed {scenario.seed}") if out_dir else None
    try:
        tel = build_network(scenario)
    except BaseException:
        if logs is not None:
            logs.close()
        raise
    if out_dir is not None and tel.hub is not None:
        tel.hub.open_log(out_dir / TELEMETRY_LOG)
    client = tel.client
    client.logs = logs
    sched = tel.scheduler
    rec = _Recorder()
    setpoints = {"ra": 0.0, "dec": 0.0}
    sensor_every = max(1, round(1e6 / scenario.log.rate_hz / SAMPLE_PERIOD_US))
    n_samples = [0]

    def sample(now_us: int) -> None:
        rec.t_us.append(now_us)
        for axis in ("ra", "dec"):
            st = client.axes[axis]
            plant = tel.plants[axis]
            rec.add(
                axis,
                counts=st.counts,
                u=st.u,
                mode=st.mode,
                setpoint=setpoints[axis],
                ia=st.current_a_a,
                ib=st.current_b_a,
                truth=plant.axis_angle_rad,
                tick_rate=st.rate_arcsec_s,  # firmware's last per-tick rate (AXIS_AUX qei_delta)
            )
        n_samples[0] += 1
        if logs is not None and n_samples[0] % sensor_every == 0:
            logs.sensor(now_us, sensor_row(client, setpoints))

    candump = None
    if out_dir is not None and tel.network is not None:
        # every frame on the bus, in Linux candump log format (`cantools decode` reads it)
        candump = CandumpWriter(out_dir / CANDUMP_LOG, "can0")
        tel.network.add_tap(candump.write)
    errors: list[str] = []
    pacer = None
    seg_spans: list[dict] = []
    total_us = int(round(scenario.duration_s * 1e6)) + client.BOOT_US + client.POWER_ON_US
    try:
        if scenario.bus.interface == "socketcan":
            # a real bus: simulated time must not outrun the wall clock, from power-on on (the
            # health check's answer window is wall-clock time for nodes outside this process)
            from host.realtime import RealtimePacer

            pacer = RealtimePacer(start_sim_us=sched.now_us)
            client.advance = lambda t_us: pacer.run_until(sched, t_us)
        healthy = client.power_on()
        if not healthy.ok:
            raise HostTimeout(
                "power-on health check failed: no answer from " + ", ".join(healthy.missing)
                + f" within {client.POWER_ON_US // 1000} ms"
            )
        schedule_faults(tel, scenario)
        sched.call_every(SAMPLE_PERIOD_US, sample, start_us=sched.now_us + SAMPLE_PHASE_US,
                         priority=PRIO_HOST, owner="host-recorder")
        for seg in scenario.segments:
            t0 = sched.now_us
            axes = ("ra", "dec") if seg.axis == "both" else (seg.axis,)
            for axis in axes:
                sp = client.command_axis(axis, seg.mode, seg.direction, seg.rate_arcsec_s)
                setpoints[axis] = sp
            if seg.focus_halfsteps is not None:
                client.command_focus_move_to(seg.focus_halfsteps)
            t_end = t0 + int(round(seg.duration_s * 1e6))
            while sched.now_us < t_end:
                if pacer is not None:  # a real bus: simulated time must not outrun the wall clock
                    nxt = min(t_end, sched.now_us + pacer.step_us)
                    pacer.wait_for(nxt)
                    sched.run_until(nxt)
                    if progress and sched.now_us % CHUNK_US < pacer.step_us:
                        progress(sched.now_us / 1e6, total_us / 1e6)
                    continue
                sched.run_until(min(t_end, sched.now_us + CHUNK_US))
                if progress:
                    progress(sched.now_us / 1e6, total_us / 1e6)
            seg_spans.append({"seg": seg, "axes": axes, "t0_us": t0, "t1_us": t_end,
                              "setpoints": {a: setpoints[a] for a in axes}})
    except SimulationError as exc:
        errors.append(str(exc))
        if logs:
            logs.error(sched.now_us, exc.owner or "simulation", "exception", str(exc).replace("\n", " "))
        raise
    except HostTimeout as exc:
        if logs:
            logs.error(sched.now_us, "host", "health-check", str(exc))
        raise
    finally:
        if logs:
            logs.close()
        if candump:
            candump.close()
        tel.close()

    window_ms = scenario.report.velocity_window_ms
    traces = {axis: rec.trace(axis) for axis in ("ra", "dec")} if rec.t_us else {}
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
            if sp != 0.0 and seg.mode != "stop":
                entry.update(segment_metrics(traces[axis], entry["t0_s"] + seg.settle_s, entry["t1_s"], sp,
                                             window_ms, rated))
            else:
                entry.update({"peak_error_pct": None, "rms_error_pct": None, "limit_cycle": False})
            segments.append(entry)
    wall_s = time.perf_counter() - wall0
    report = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": scenario.seed,
        "bus": scenario.bus.model_dump(),
        "simulated_s": sched.now_us / 1e6,
        "wall_s": round(wall_s, 3),
        "method": MEASUREMENT_METHOD,
        "velocity_window_ms": window_ms,
        "segments": segments,
        "controller": tel.controller_summary(),
        "plant": tel.plant_summary(),
        "gear_lines": {axis: p.gear_lines for axis, p in tel.plants.items()},  # issue 9: lines that ran
        "bus_stats": tel.bus_stats(),
        "boards": tel.board_summary(),
        "rs232": tel.rs232_summary(),
        "errors": errors + client.error_lines(),
        "realtime": pacer.stats() if pacer is not None else None,
    }
    files: list[Path] = []
    if out_dir is not None:
        files += list(logs.paths.values())
        if candump:
            files.append(candump.path)
        if tel.hub is not None and tel.hub.log_path is not None:
            files.append(tel.hub.log_path)
        files += list(write_reports(out_dir, report))
        if plots and traces:
            files += plot_axes(out_dir, traces, segments, window_ms)
    return RunResult(report=report, files=files)


def sensor_row(client, setpoints: dict) -> tuple:
    """One ``sensor.log`` row after ``t_s`` (columns :data:`host.logs.SENSOR_COLUMNS`): what the
    host client has decoded from the status frames, with each axis's setpoint.

    Parameters
    ----------
    client : host.client.HostClient
        The host client whose decoded status is logged.
    setpoints : dict
        ``{"ra": ..., "dec": ...}``, the setpoint rate of each axis [arcsec/s].
    """
    row = []
    for axis in ("ra", "dec"):
        st = client.axes[axis]
        row += [st.mode_name, f"{setpoints[axis]:.4f}", st.rate_arcsec_s, st.u, st.counts,
                st.current_a_a, st.current_b_a, client.positions[axis].pos_counts]
    row += [client.focus.pos_halfsteps, client.focus.lvdt_adc]
    return tuple(row)


def schedule_faults(tel, scenario: Scenario) -> None:
    """Schedule the scenario's injected faults on the simulated clock (``at_s`` after now)."""
    for f in scenario.faults:
        t_us = tel.scheduler.now_us + int(round(f.at_s * 1e6))
        tel.scheduler.call_at(t_us, lambda now_us, f=f: tel.inject_fault(f, now_us), priority=PRIO_HOST,
                              owner=f"fault:{f.kind}")
