"""Build the emulated telescope network from a scenario: the ONE place where boards, bus and
plant are wired together (the assembly).

Which boards exist comes from the registry (:mod:`boards.registry`); this module only knows how
to reach the plant for each *port* a board's firmware asks for (:data:`PORTS`) and which
settings a board kind takes from the parameter file and the scenario (:data:`SETTINGS`).
Boards never see plant objects: each port is a callable — PWM duty → motor voltages, shaft
angle → QEI counts / EnDat position word, armature current → shunt voltage → ADC. The plants
are advanced lazily to the scheduler's time by every port and also by a 50 ms plant event on the
same clock (so the plant keeps moving when a board is reset or removed).

Decisions written down here:

* **Gains**: :func:`boards.tuning.design_axis_gains` (low-preload σ2, paper §4); a scenario may
  override ``kp``/``ki``.
* **Open-loop duty** (the operator's duty–speed map): :func:`plant.drive_map.open_loop_duty`
  with the counter fraction the axis firmware runs (read from the board, so a scenario's
  ``controller.<axis>.counter_fraction`` reaches the map too).
* **Encoder resolution** the host uses (rates in ``sensor.log`` and the report): read from the
  axis boards that ran (``AxisController.arcsec_per_count``), i.e. the parameter file's encoder.
* **RS232 telemetry** (§3.4, scenario ``rs232``): one :class:`bus.serial_link.SerialLink` per
  board at the scenario's baud (8N1); the board's end goes to its firmware's ``serial_port``
  (its UART), the other end to the host's :class:`host.rs232.Rs232Hub`, which is woken by the
  link's receive callback once per packet (no per-byte or per-sample events).
* **Focus encoder**: the focus firmware's QEI reads ``FocusPlant.motor_encoder_counts`` and is
  told the parameter file's counts per revolution.
* **Reports read what ran**: :meth:`Telescope.plant_summary` reads the plants (their friction
  after effects, their parameters), :meth:`Telescope.controller_summary` and
  :meth:`Telescope.board_summary` read the boards; nothing reads the input files again.
"""

from __future__ import annotations

from collections.abc import Mapping

import itertools
from dataclasses import dataclass, field
from typing import Callable

import can

import bus as _bus_pkg  # noqa: F401  (registers the schmidt-sim python-can interface)
from boards.axis_controller import PRESET_RATES_ARCSEC_S, AxisMode
from boards.peripherals import Adc
from boards.registry import BOARD_NAMES, BOARDS, BoardInstance
from boards.tuning import GAINS_SOURCE, design_axis_gains
from bus import protocol as P
from bus.network import CanNetwork
from bus.scheduler import PRIO_PLANT, Scheduler
from bus.serial_link import SerialLink
from bus.units import TICK_US
from host import faults as _faults
from host.client import HostClient
from host.rs232 import Rs232Hub
from host.scenario import Scenario, resolve_parameters
from plant.axis import AxisPlant
from plant.drive_map import open_loop_duty
from plant.focus import FocusPlant
from plant.params import PlantParameters

__all__ = ["Telescope", "build_network", "PORTS", "SETTINGS", "BOARD_NAMES"]

#: Plant keep-alive period [µs]: every port advances the plant to the current time before it
#: reads or writes, so the plant is exact at each ISR; this event only keeps it moving when no
#: board touches it (a board reset or removed), and bounds the lazy catch-up.
PLANT_PERIOD_US = 50_000
AXES = ("ra", "dec")
_unique = itertools.count(1)


@dataclass
class Telescope:
    """The built network: clock, CAN bus, plants, boards and host client.

    Attributes
    ----------
    boards : dict
        Board name -> firmware object, in node order (names from :mod:`boards.registry`).
    plants : dict
        ``"ra"``/``"dec"`` -> :class:`plant.axis.AxisPlant`.
    gains : dict
        Per axis: where the PI gains came from and the tuning model's numbers.
    """

    scenario: Scenario
    scheduler: Scheduler
    params: PlantParameters
    network: CanNetwork | None
    plants: dict
    focus_plant: FocusPlant
    boards: dict
    client: HostClient
    gains: dict
    buses: list = field(default_factory=list)
    removed: set = field(default_factory=set)
    hub: Rs232Hub | None = None
    serial_links: dict = field(default_factory=dict)
    _can_snapshot: dict = field(default_factory=dict, repr=False)   # CAN registers at close()

    def advance_plants(self, now_us: int | None = None) -> None:
        """Advance every plant to ``now_us`` (default the scheduler's time)."""
        t = self.scheduler.now_us if now_us is None else now_us
        for p in self.plants.values():
            p.advance_to(t)
        self.focus_plant.advance_to(t)

    def inject_fault(self, fault, now_us: int) -> None:
        """Apply one scenario fault (the table :data:`host.faults.FAULTS`)."""
        _faults.inject(self, fault, now_us)

    def axis_board(self, axis: str):
        """The axis controller of ``axis`` (``"ra"``/``"dec"``)."""
        return self.boards[_AXIS_BOARD[axis]]

    # -- summaries for the report: the state of what ran -------------------------------------
    def controller_summary(self) -> dict:
        """Per axis: the gains, limits and drive law the axis firmware runs."""
        out = {}
        for axis in AXES:
            b, g = self.axis_board(axis), self.gains[axis]
            out[axis] = {"kp_duty_per_arcsec_s": b.kp0, "ki_duty_per_arcsec_s_tick": b.ki0,
                         "u_max": b.u_max, "counter_fraction": b.counter_fraction, "drive_law": b.law_name,
                         "gains_source": g["source"], **{k: v for k, v in g.items() if k != "source"}}
        return out

    def plant_summary(self) -> dict:
        """Per axis: the friction the plant integrates (after effects), its inertia, drive model
        and current peaks; read from the plant objects, not the parameter file."""
        out = {"perfect": self.params.perfect}
        for axis, p in self.plants.items():
            ap, fr = p.params, p.friction
            d = {
                "preload": ap.friction.preload, "sigma2_nm_s_rad": fr.sigma2_pos_nm_s_rad, "tc_nm": fr.tc_pos_nm,
                "ts_nm": fr.ts_nm, "omega_s_rad_s": fr.omega_s_rad_s, "sigma0_nm_rad": fr.sigma0_nm_rad,
                "sigma1_nm_s_rad": fr.sigma1_nm_s_rad, "inertia_kg_m2": ap.inertia_kg_m2,
                "drive_model": ap.drive_model, "max_substep_us": p.max_substep_us,
                "peak_current_a": [round(float(i), 3) for i in p.peak_current_a],
                "time_over_rating_s": [round(t / 1e6, 3) for t in p.current_over_rating_us],
                "effects": [e.kind for e in p.effects],
            }
            if fr.tc_neg_nm != fr.tc_pos_nm or fr.sigma2_neg_nm_s_rad != fr.sigma2_pos_nm_s_rad:
                d.update(tc_neg_nm=fr.tc_neg_nm, sigma2_neg_nm_s_rad=fr.sigma2_neg_nm_s_rad)  # asymmetric
            out[axis] = d
        return out

    def bus_stats(self) -> dict:
        """Frames, bits, load and latency of the emulated bus (a note on other buses)."""
        if self.network is None:
            return {"interface": self.scenario.bus.interface, "note": "no bit timing on this bus"}
        s = self.network.stats()
        return {
            "interface": "sim", "bitrate": self.network.bitrate, "frames": s["frames"], "bits": s["bits"],
            "load_pct": round(s["load_pct"], 3), "peak_load_pct": round(s["peak_load_pct"], 3),
            "max_latency_us": {P.frame_name(k): v for k, v in s["max_latency_us"].items()},
            "frames_by_id": {P.frame_name(k): v for k, v in s["per_id"].items()},
            "error_frames": s.get("error_frames", 0), "error_bits": s.get("error_bits", 0),
        }

    def board_summary(self) -> dict:
        """One row per board (registry order): node, counters, state; each board adds its own
        counters through ``report_counters()``."""
        out = {}
        for name, b in self.boards.items():
            d = {"node": b.node_id, "malformed_frames": b.malformed_frames,
                 # the host's view first: a board whose heartbeat stopped is LOST whatever it was
                 "state": "LOST" if b.node_id in self.client.lost else b.device.state,
                 "emcy_sent": b.device.emcy.sent,
                 "reset_cause": b.reset_cause, "resets": b.reset_count,
                 "can": self._can_snapshot.get(name) or _can_registers(b)}
            d.update(b.report_counters())
            if BOARDS[name][0].kind == "focus_controller":   # the plant's truth beside the firmware's count
                d["plant_lost_halfsteps"] = self.focus_plant.lost_halfsteps
            if b.uart is not None:
                d["telemetry_packets_sent"] = b.uart.tx_writes
                d["telemetry_late_writes"] = b.uart.tx_late
            out[name] = d
        return out

    def rs232_summary(self) -> dict | None:
        """Per-port telemetry counters of the hub (None when RS232 is off)."""
        return self.hub.counters() if self.hub is not None else None

    def close(self) -> None:
        """Shut every bus down and unregister the CAN channel (idempotent). The boards' CAN
        error registers are kept for the report (they live in the bus model)."""
        if not self._can_snapshot:
            self._can_snapshot.update({name: _can_registers(b) for name, b in self.boards.items()})
        self.client.close()
        if self.hub is not None:
            self.hub.close()
        for b in self.buses:
            try:
                b.shutdown()
            except Exception:  # noqa: BLE001 - closing must not hide the run's own error
                pass
        if self.network is not None:
            self.network.close()


_AXIS_BOARD = {i.axis: name for name, (s, i) in BOARDS.items() if s.kind == "axis_controller"}


def _can_registers(board) -> dict:
    """TEC, REC and error state of a board's CAN controller (as its registers show them)."""
    return {"tec": board.can.tec, "rec": board.can.rec, "error_state": board.can.error_state}


def _make_bus(scenario: Scenario, channel: str) -> can.BusABC:
    iface = scenario.bus.interface
    if iface == "sim":
        return can.Bus(interface="schmidt-sim", channel=channel)
    if iface == "virtual":
        return can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    # One socket per board and one for the host: the kernel loops each frame back to the other
    # sockets on this machine (python-can's default local_loopback) but not to its sender
    # (receive_own_messages off), as on a real bus. python-can subscribes every socket to the
    # controller's error frames by default; a CAN controller reports bus errors in its status
    # registers, not as received messages, so boards and host must not see them as frames (they
    # counted them as malformed: found on vcan0, tests/test_vcan.py).
    return can.Bus(interface="socketcan", channel=scenario.bus.channel, receive_own_messages=False,
                   ignore_rx_error_frames=True)


@dataclass
class _Build:
    """What port factories and settings see while the network is built."""

    scenario: Scenario
    scheduler: Scheduler
    params: PlantParameters
    plants: dict
    focus_plant: FocusPlant
    gains: dict


def _advancing(plant, sched: Scheduler, fn: Callable) -> Callable:
    """``fn`` wrapped so that ``plant`` is advanced to the scheduler's time first."""
    def port(*args):
        plant.advance_to(sched.now_us)
        return fn(*args)
    return port


#: Port name (a firmware keyword argument, ``BoardSpec.ports``) -> factory(build, instance) ->
#: the callable handed to the firmware. A new board kind that needs a plant quantity no board has
#: yet adds one factory here.
PORTS: dict[str, Callable[[_Build, BoardInstance], Callable]] = {
    "read_qei_counts": lambda b, i: _advancing(b.plants[i.axis], b.scheduler, b.plants[i.axis].qei_counts),
    "on_duties": lambda b, i: _advancing(b.plants[i.axis], b.scheduler, b.plants[i.axis].set_duties),
    "shunt_a_v": lambda b, i: _advancing(b.plants[i.axis], b.scheduler, lambda p=b.plants[i.axis]: p.shunt_voltage_v("a")),
    "shunt_b_v": lambda b, i: _advancing(b.plants[i.axis], b.scheduler, lambda p=b.plants[i.axis]: p.shunt_voltage_v("b")),
    "read_position_word": lambda b, i: _advancing(b.plants[i.axis], b.scheduler, b.plants[i.axis].absolute_counts),
    "on_step": lambda b, i: _advancing(b.focus_plant, b.scheduler, b.focus_plant.step),
    "on_power": lambda b, i: _advancing(b.focus_plant, b.scheduler, b.focus_plant.set_power),
    # the kinematic focus plant changes only on step()/set_power(), so its read-only sensors
    # need no advance_to: direct ports (cheaper; sampled every 10 ms with RS232)
    "read_lvdt_v": lambda b, i: b.focus_plant.lvdt_voltage_v,
    "read_index": lambda b, i: b.focus_plant.at_index,
    "read_encoder_counts": lambda b, i: b.focus_plant.motor_encoder_counts,
}


class _LivePresets(Mapping):
    """``{(mode name, axis): ″/s}`` read from the axis boards' current presets (object 0x2001,
    writable by SDO), so the host's setpoints follow a write: one source, the firmware."""

    _MODES = {AxisMode.NAMES[m].lower(): int(m) for m in PRESET_RATES_ARCSEC_S}

    def __init__(self, boards: dict) -> None:
        self._boards = boards

    def _key_ok(self, key) -> bool:
        return isinstance(key, tuple) and len(key) == 2 and key[0] in self._MODES and key[1] in AXES

    def __getitem__(self, key):
        if not self._key_ok(key):
            raise KeyError(key)
        mode, axis = key
        return self._boards[_AXIS_BOARD[axis]].preset_rates_arcsec_s[self._MODES[mode]]

    def __iter__(self):
        return iter([(m, a) for m in self._MODES for a in AXES])

    def __len__(self) -> int:
        return len(self._MODES) * len(AXES)


def _axis_settings(b: _Build, i: BoardInstance) -> dict:
    ap = b.params.axes[i.axis]
    cc = getattr(b.scenario.controller, i.axis)
    p = ap.drive.counter_fraction if cc.counter_fraction is None else cc.counter_fraction
    g = design_axis_gains(ap, p, TICK_US)
    gd = g.as_dict()
    b.gains[i.axis] = {"source": GAINS_SOURCE if cc.kp is None and cc.ki is None else "scenario override",
                       **{f"model_{k}": v for k, v in gd.items() if k not in ("kp", "ki")}}
    return dict(kp=g.kp if cc.kp is None else cc.kp, ki=g.ki if cc.ki is None else cc.ki,
                u_max=1.0 if cc.u_max is None else cc.u_max, counter_fraction=p, law=ap.drive.preload_law,
                qei_counts_per_rev=int(round(ap.encoders.incremental_counts_per_rev * ap.encoders.roller_ratio)),
                shunt_ohm=ap.motor.shunt_ohm, overcurrent_a=ap.motor.rated_current_a)


#: Board kind -> settings(build, instance) -> extra firmware keyword arguments taken from the
#: parameter file and the scenario. Kinds without an entry take none.
SETTINGS: dict[str, Callable[[_Build, BoardInstance], dict]] = {
    "axis_controller": _axis_settings,
    "focus_controller": lambda b, i: {"encoder_counts_per_rev": b.params.focus.motor_encoder_counts_per_rev},
}


def build_network(scenario: Scenario, host_cls: type[HostClient] = HostClient) -> Telescope:
    """Build clock, bus, plants, boards and host client for ``scenario`` (boards started).

    Parameters
    ----------
    scenario : Scenario
        What to build (``bus``, ``plant``, ``controller``, ``rs232``).
    host_cls : type
        The host node's class: :class:`host.client.HostClient` (default) or a subclass such as
        :class:`host.monitor.BusMonitor` (``schmidt-fil serve``: a passive monitor, so that a
        host program outside the emulator commands the boards).

    Returns
    -------
    Telescope
        On the ``sim`` bus, ``tel.network.channel`` is the channel a host of your own opens with
        ``can.Bus(interface="schmidt-sim", channel=...)`` (docs/serve.md).

    Raises
    ------
    ScenarioError
        Parameter file or overrides invalid.
    """
    params = resolve_parameters(scenario)
    sched = Scheduler()
    iface = scenario.bus.interface
    channel = f"{scenario.bus.channel}#{next(_unique)}" if iface != "socketcan" else scenario.bus.channel
    network = CanNetwork(sched, channel, scenario.bus.bitrate) if iface == "sim" else None
    buses: list = []

    def new_bus() -> can.BusABC:
        b = _make_bus(scenario, channel)
        buses.append(b)
        return b

    plants = {axis: AxisPlant(params.axes[axis], name=axis) for axis in AXES}
    focus_plant = FocusPlant(params.focus)

    def plant_tick(now_us: int) -> None:
        for p in plants.values():
            p.advance_to(now_us)

    sched.call_every(PLANT_PERIOD_US, plant_tick, start_us=0, priority=PRIO_PLANT, owner="plant")

    # host first, so it hears the boards' boot heartbeats
    boards: dict = {}
    adc = Adc({})
    shunt = params.axes["ra"].motor.shunt_ohm
    # the setpoints the host reports are the presets the axis firmware holds now (0x2001 is rw)
    preset = _LivePresets(boards)
    client = host_cls(
        bus=new_bus(), scheduler=sched, preset_rates_arcsec_s=preset,
        # the duty-speed map with the counter fraction the axis firmware runs
        open_loop_duty=lambda rate, axis: open_loop_duty(rate, params.axes[axis],
                                                         boards[_AXIS_BOARD[axis]].counter_fraction),
        adc_to_current_a=lambda c: adc.to_volts(c) / shunt,
    )

    # RS232 telemetry: one point-to-point link per board, the far ends on the host's hub
    rs = scenario.rs232
    hub = Rs232Hub(sched, rs.baud) if rs.enabled else None
    links = {name: SerialLink(sched, baud=rs.baud, name=f"rs232-{name}") for name in BOARD_NAMES} if hub else {}

    build = _Build(scenario, sched, params, plants, focus_plant, {})
    for name, (spec, inst) in BOARDS.items():
        kwargs = {port: PORTS[port](build, inst) for port in spec.ports}
        kwargs.update(SETTINGS.get(spec.kind, lambda b, i: {})(build, inst))
        boards[name] = spec.firmware(sched, new_bus(), inst.node_id, name=name,
                                     serial_port=links[name].a if links else None, **kwargs)
    client.arcsec_per_count = {axis: boards[_AXIS_BOARD[axis]].arcsec_per_count for axis in AXES}
    if hub is not None:
        for name in BOARD_NAMES:
            hub.add_port(links[name].b, name, boards[name].node_id)
    for b in boards.values():
        b.start()
    return Telescope(scenario=scenario, scheduler=sched, params=params, network=network, plants=plants,
                     focus_plant=focus_plant, boards=boards, client=client, gains=build.gains, buses=buses,
                     hub=hub, serial_links=links)
