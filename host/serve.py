"""Serve the emulated telescope to a host program outside the emulator (``schmidt-fil serve``).

A :class:`ServeSession` builds the five boards and the plant from a scenario's ``bus``,
``plant``, ``controller``, ``log``, ``rs232`` and ``faults`` sections (its ``segments`` are not
run) with :func:`host.network.build_network`, and puts a passive :class:`host.monitor.BusMonitor`
in the host's place: the external host commands, the monitor writes the four §5.2 logs
(``commands.log`` = the external host's commands), ``candump.log`` and, on :meth:`close`,
``report.json``/``report.md`` (frames seen per identifier, bus statistics, board counters, the
plant's truth). On SocketCAN :meth:`ServeSession.run` paces simulated time to the wall clock with
:class:`host.realtime.RealtimePacer`; on the in-process ``sim`` bus a Python host in the same
process drives ``session.tel.scheduler.run_until`` itself (docs/serve.md).

Signals and the wall clock stay here and in ``host/cli_serve.py``: boards and plant never see
them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable

import can

from boards.registry import BOARDS, GATEWAY_KIND, network_boards
from bus import protocol as P
from bus.errors import BusError, SimulationError
from bus.units import ARCSEC_PER_RAD
from host.monitor import BusMonitor
from host.network import build_network
from host.report import _json_default
from host.scenario import BusConfig, Scenario
from host.session import Session

__all__ = ["ServeSession", "SocketCanUnavailable", "DEFAULT_SCENARIO", "DEFAULT_CHANNEL", "serve_scenario",
           "served_interface"]

#: Scenario ``serve`` takes the plant from when none is given: RA tracking at low preload (the
#: README's main job), i.e. the packaged parameters with the Table 2 low-preload friction set.
DEFAULT_SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "tracking-low-preload.yaml"
#: SocketCAN interface served when neither ``--channel`` nor a socketcan scenario names one.
DEFAULT_CHANNEL = "vcan0"
#: Simulated time between flushes of ``candump.log`` while serving [µs] (the four logs are
#: line-buffered; the frame log is block-buffered for speed).
FLUSH_PERIOD_US = 1_000_000
#: Errors listed in ``report.json`` (all of them are in ``errors.log``).
REPORT_MAX_ERRORS = 200


class SocketCanUnavailable(BusError):
    """The SocketCAN interface cannot be opened (no AF_CAN in this kernel, interface missing or
    down)."""


def serve_scenario(scenario: Scenario, channel: str | None = None) -> Scenario:
    """``scenario`` on SocketCAN: ``bus.interface`` becomes ``socketcan`` and ``bus.channel``
    ``channel`` (default: the scenario's own channel if it is already socketcan, else
    :data:`DEFAULT_CHANNEL`). Everything else is kept."""
    if channel is None:
        channel = scenario.bus.channel if scenario.bus.interface == "socketcan" else DEFAULT_CHANNEL
    bus = BusConfig(interface="socketcan", channel=channel, bitrate=scenario.bus.bitrate)
    return scenario.model_copy(update={"bus": bus})


def served_interface(network="basic") -> list[dict]:
    """What the emulated boards offer on the bus, per board in node order: node id, the COB-IDs
    it sends and the COB-IDs a host sends to it (from the board registry, :mod:`boards.registry`),
    for the boards of ``network`` (a scenario's ``network``: name or list of boards). Not the
    USB gateway: it is the host's node, unpowered in ``serve`` (your program is the host).

    Returns
    -------
    list of dict
        ``{"board", "node", "sends": [(cob_id, name), ...], "listens": [(cob_id, name), ...]}``.
    """
    return [{"board": name, "node": int(inst.node_id), "sends": spec.sends(inst.node_id),
             "listens": spec.accepts(inst.node_id)}
            for name, (spec, inst) in ((n, BOARDS[n]) for n in network_boards(network))
            if spec.kind != GATEWAY_KIND]


class ServeSession(Session):
    """The boards and plant of ``scenario`` with a passive monitor in the host's place.

    Parameters
    ----------
    scenario : Scenario
        Validated scenario; its ``segments`` are ignored. For the command line it has been put on
        SocketCAN by :func:`serve_scenario`; on ``sim`` an in-process host opens
        ``can.Bus(interface="schmidt-sim", channel=session.tel.network.channel)``.
    out_dir : Path or str
        Directory for the logs and the report (created).

    Raises
    ------
    SocketCanUnavailable
        The scenario is on SocketCAN and its channel cannot be opened.
    ScenarioError
        Plant parameter file or overrides invalid.

    Notes
    -----
    Time in the logs is simulated seconds since power-on (on SocketCAN: wall-clock seconds since
    :meth:`run` started, up to the pacer's lateness). The boards boot at time 0; the monitor
    sends no health check, no NMT and no command (only an injected ``malformed_frame`` fault puts a frame of
    its own on the bus).
    """

    def __init__(self, scenario: Scenario, out_dir: Path | str):
        iface, channel = scenario.bus.interface, scenario.bus.channel

        def build(sc: Scenario, host_cls: type):
            try:
                return build_network(sc, host_cls=host_cls)
            except (OSError, can.CanError) as exc:
                if iface != "socketcan":
                    raise
                raise SocketCanUnavailable(
                    f"cannot open SocketCAN channel {channel!r} ({exc}); serving needs a Linux kernel with "
                    f"AF_CAN and the interface up (e.g. 'sudo ip link add dev vcan0 type vcan && sudo ip link "
                    f"set vcan0 up'); see docs/socketcan.md") from None

        super().__init__(scenario, out_dir, host_cls=BusMonitor, logs_first=False, build=build,
                         candump_channel="can0" if iface == "sim" else channel,
                         header=(f"serve {scenario.name}; seed {scenario.seed}; bus {iface} {channel}; commands are "
                                 f"those seen from the external host"))
        self.monitor: BusMonitor = self.tel.client
        self.stopped_by: str | None = None
        self.report: dict | None = None
        self.schedule_faults()
        self._truth = {axis: {"t0_us": None, "angle0_rad": 0.0, "peak_abs_rate_rad_s": 0.0}
                       for axis in self.tel.plants}
        self.start_sampling("host-monitor", self._track_truth)
        self._next_flush_us = self.scheduler.now_us + FLUSH_PERIOD_US

    @property
    def pacer(self):
        """The real-time pacer on SocketCAN once :meth:`run` has started (else ``None``)."""
        return self.clock if self.paced else None

    # -- sampling (simulated time) -------------------------------------------------------------
    def _track_truth(self, now_us: int) -> None:
        for axis, plant in self.tel.plants.items():
            tr = self._truth[axis]
            if tr["t0_us"] is None:
                tr["t0_us"], tr["angle0_rad"] = now_us, plant.axis_angle_rad
            tr["peak_abs_rate_rad_s"] = max(tr["peak_abs_rate_rad_s"], abs(plant.axis_rate_rad_s))

    # -- running -------------------------------------------------------------------------------
    def run(self, duration_s: float | None = None, should_stop: Callable[[], bool] | None = None) -> str:
        """Advance the network until ``duration_s`` more seconds have passed or ``should_stop()``
        is true (checked every 5 ms step on SocketCAN, every 0.2 s of simulated time otherwise).

        On SocketCAN each 5 ms step waits for the wall clock (:class:`RealtimePacer`; lateness
        goes to the report). Elsewhere it runs in simulated time as fast as it can.

        Returns
        -------
        str
            Why it stopped: ``"duration"`` or ``"stop requested"``.

        Raises
        ------
        ValueError
            Neither a duration nor a stop condition (it would never return).
        SimulationError
            A board or the plant raised (logged in ``errors.log``; call :meth:`close` after).
        """
        if duration_s is None and should_stop is None:
            raise ValueError("run() needs duration_s or should_stop")
        sched = self.scheduler
        end_us = None if duration_s is None else sched.now_us + int(round(duration_s * 1e6))

        def flush() -> None:
            if sched.now_us >= self._next_flush_us:
                self.candump.flush()
                self._next_flush_us = sched.now_us + FLUSH_PERIOD_US

        try:
            reached = self.advance(end_us, should_stop, flush)
        except SimulationError:
            self.stopped_by = "simulation error"
            raise
        self.stopped_by = "duration" if reached else "stop requested"
        return self.stopped_by

    # -- closing and the report ----------------------------------------------------------------
    def close(self) -> dict:
        """Write ``report.json``/``report.md``, flush and close every log, shut the buses down
        (idempotent; the logs are closed even if the report fails).

        Returns
        -------
        dict
            The report (also in ``report.json``).
        """
        if self.report is not None:
            return self.report
        try:
            report = self._report()
            (self.out_dir / "report.json").write_text(json.dumps(report, indent=2, default=_json_default) + "\n",
                                                      encoding="utf-8")
            (self.out_dir / "report.md").write_text(_markdown(report), encoding="utf-8")
            self.report = report
        finally:
            Session.close(self)
        return report

    def __enter__(self) -> "ServeSession":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def files(self) -> list[Path]:
        """Files written into ``out_dir``."""
        names = [*Session.files(self), self.out_dir / "report.json", self.out_dir / "report.md"]
        return [p for p in names if p.exists()]

    def _report(self) -> dict:
        tel, mon, sched = self.tel, self.monitor, self.scheduler
        boards = tel.board_summary()
        for name, b in tel.boards.items():
            if hasattr(b, "limit_refusals"):
                boards[name]["limit_refusals"] = b.limit_refusals
        truth = {}
        for axis, plant in tel.plants.items():
            tr = self._truth[axis]
            span_s = (sched.now_us - tr["t0_us"]) / 1e6 if tr["t0_us"] is not None else 0.0
            angle1 = plant.axis_angle_rad
            truth[axis] = {
                "angle_start_deg": round(math.degrees(tr["angle0_rad"]), 6),
                "angle_end_deg": round(math.degrees(angle1), 6),
                "mean_rate_arcsec_s": round((angle1 - tr["angle0_rad"]) * ARCSEC_PER_RAD / span_s, 4) if span_s > 0 else None,
                "peak_abs_rate_arcsec_s": round(tr["peak_abs_rate_rad_s"] * ARCSEC_PER_RAD, 4),
            }
        plant = tel.plant_summary()
        for axis in truth:
            plant[axis]["truth"] = truth[axis]
        errors = self.errors + mon.error_lines()
        extra = {}
        if self.maintenance is not None:            # issue 12: §5.2 maintenance quantities
            extra["maintenance"] = self.maintenance.summary(
                {axis: round(p.params.gear.ratio, 4) for axis, p in tel.plants.items()})
        return {
            "command": "serve",
            "network": tel.network_name,
            "nodes": {name: b.node_id for name, b in tel.boards.items()},
            "scenario": self.scenario.name,
            "scenario_file": self.scenario.source_path,
            "seed": self.scenario.seed,
            "bus": self.scenario.bus.model_dump(),
            "simulated_s": sched.now_us / 1e6,
            "wall_s": self.wall_s(),
            "stopped_by": self.stopped_by,
            "frames_seen": {P.frame_name(k): v for k, v in sorted(mon.frames_by_id.items())},
            "frames_seen_total": mon.frames_received,
            "external_commands": dict(sorted(mon.commands_seen.items())),
            "monitor": {"malformed_frames": mon.malformed_frames, "limit_frames": mon.limit_frames,
                        "candump_frames": self.candump.frames if self.candump else 0},
            "bus_stats": tel.bus_stats(),
            "boards": boards,
            "controller": tel.controller_summary(),
            "plant": plant,
            "rs232": tel.rs232_summary(),
            "realtime": self.clock_stats(),
            "errors_total": len(errors),
            "errors": errors[:REPORT_MAX_ERRORS],
            **extra,
        }


def _markdown(r: dict) -> str:
    """``report.md`` of a serve session."""
    lines = [f"# schmidt-fil serve: {r['scenario']}", "",
             f"Served {r['simulated_s']:.1f} s simulated in {r['wall_s']:.1f} s wall on `{r['bus']['interface']}` "
             f"`{r['bus']['channel']}`; stopped by {r['stopped_by'] or 'an error'}.", ""]
    rt = r.get("realtime")
    if rt:
        lines += [f"Pacing: {rt['steps']} steps of 5 ms, {rt['late_steps']} late (p99 {rt['p99_late_us'] / 1000:.1f} ms, "
                  f"max {rt['max_late_us'] / 1000:.1f} ms), real-time factor {rt['realtime_factor']}.", ""]
    lines += ["## External commands", ""]
    lines += [f"- {k}: {v}" for k, v in r["external_commands"].items()] or ["- none"]
    lines += ["", "## Frames seen by the monitor", "", "| frame | count |", "|---|---:|"]
    lines += [f"| {k} | {v} |" for k, v in r["frames_seen"].items()]
    m = r["monitor"]
    lines += ["", f"Total {r['frames_seen_total']}; malformed (as the host decodes them) {m['malformed_frames']}; "
              f"LIMIT frames {m['limit_frames']}.", ""]
    b = r["bus_stats"]
    if "load_pct" in b:
        lines += [f"Bus: {b['frames']} frames, load {b['load_pct']:.2f} % (peak {b['peak_load_pct']:.2f} % over 100 ms).", ""]
    else:
        lines += [f"Bus: {b.get('note', '')}.", ""]
    lines += ["## Boards", "", "| board | state | malformed frames | CRC errors | limit refusals | resets |",
              "|---|---|---:|---:|---:|---:|"]
    for name, d in r["boards"].items():
        lines.append(f"| {name} | {d['state']} | {d['malformed_frames']} | {d.get('crc_errors', '–')} | "
                     f"{d.get('limit_refusals', '–')} | {d['resets']} |")
    lines += ["", "## Plant truth", "", "| axis | start (°) | end (°) | mean rate (″/s) | peak abs. rate (″/s) | peak currents (A) |",
              "|---|---:|---:|---:|---:|---|"]
    for axis in ("ra", "dec"):
        t, p = r["plant"][axis]["truth"], r["plant"][axis]
        lines.append(f"| {axis} | {t['angle_start_deg']:.4f} | {t['angle_end_deg']:.4f} | {t['mean_rate_arcsec_s']} | "
                     f"{t['peak_abs_rate_arcsec_s']} | {p['peak_current_a']} |")
    if r["errors"]:
        lines += ["", f"## Errors ({r['errors_total']})", ""] + [f"- {e}" for e in r["errors"]]
    return "\n".join(lines) + "\n"
