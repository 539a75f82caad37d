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
* **Room nodes** (issue 12: display, dome, weather): on the networks that name them (``full``,
  or a list; ``build_network(..., boards=[...])`` overrides the scenario's network). The dome's plant is :class:`plant.dome.DomePlant`, the weather station reads
  :class:`plant.weather.WeatherModel` (seed: the scenario's ``weather.seed`` or ``seed``; its
  scripted ``weather.events``), the display writes to :class:`host.logs.DisplayLog`
  (``display.log``). The room nodes have no RS232 telemetry layout, so no serial link.
* **The host's path** (paper §3.4): the commanding host client talks to the bus through the
  USB-HID gateway, a board of the registry (kind ``usb_gateway``, node 0x10): its USB side is
  plugged into a private simulated USB host (:class:`host.hid_device.SimUsb`), a
  :class:`host.hid_device.device` is opened on it and the client's bus is a
  :class:`host.gateway_bus.HidGatewayBus` over that device. So frames reach the client at the
  next 1 ms USB frame and its commands leave at the next one (docs/usb-gateway.md). A host class
  with ``THROUGH_GATEWAY = False`` (the passive :class:`host.monitor.BusMonitor` of ``serve``, a
  listener on the CAN bus) gets a CAN bus handle of its own, and the gateway stays unpowered
  (bus-powered from the PC's USB, which ``serve`` does not have).
* **Reports read what ran**: :meth:`Telescope.plant_summary` reads the plants (their friction
  after effects, their parameters), :meth:`Telescope.controller_summary` and
  :meth:`Telescope.board_summary` read the boards; nothing reads the input files again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import itertools
from functools import partial
from dataclasses import dataclass, field
from typing import Callable

import can

import bus as _bus_pkg  # noqa: F401  (registers the schmidt-sim python-can interface)
from boards.axis_controller import PRESET_RATES_ARCSEC_S, AxisMode
from boards.peripherals import Adc
from host.ports import AxisPlantPort, PlantPort
from boards.registry import BOARD_NAMES, BOARDS, GATEWAY_KIND, BoardInstance, canopen_nodes, network_boards
from boards.tuning import GAINS_SOURCE, design_axis_gains
from boards.usb_hid import PRODUCT_ID, VENDOR_ID
from bus import protocol as P
from bus import telemetry as T
from bus.network import CanNetwork
from bus.scheduler import PRIO_PLANT, Scheduler
from bus.serial_link import SerialLink
from bus.telemetry import SAMPLE_FIELDS
from bus.units import TICK_US
from host import faults as _faults
from host import hid_device
from host.client import AdcCurrent, HostClient
from host.logs import DisplayLog
from host.gateway_bus import HidGatewayBus
from host.rs232 import Rs232Hub
from host.scenario import Scenario, resolve_parameters
from plant.axis import AxisPlant
from plant.drive_map import open_loop_duty
from plant.dome import DomePlant
from plant.focus import FocusPlant
from plant.weather import WeatherEvent, WeatherModel
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
    dome_plant: DomePlant | None = None          # issue 12, room nodes
    weather: WeatherModel | None = None
    display_log: DisplayLog | None = None
    #: the USB host port of the gateway the client talks through (None: a direct host)
    usb_port: object = None
    _can_snapshot: dict = field(default_factory=dict, repr=False)   # CAN registers at close()
    _error_counters_snapshot: dict = field(default_factory=dict, repr=False)   # the bus's, at close()
    network_name: str = "basic"     #: the scenario's ``network`` (a name, or "custom" for a list)

    def advance_plants(self, now_us: int | None = None) -> None:
        """Advance every plant to ``now_us`` (default the scheduler's time)."""
        t = self.scheduler.now_us if now_us is None else now_us
        for p in self.plants.values():
            p.advance_to(t)
        self.focus_plant.advance_to(t)
        for p in (self.dome_plant, self.weather):
            if p is not None:
                p.advance_to(t)

    def inject_fault(self, fault, now_us: int) -> None:
        """Apply one scenario fault (the table :data:`host.faults.FAULTS`)."""
        _faults.inject(self, fault, now_us)

    @property
    def host_can_bus(self) -> can.BusABC:
        """The CAN bus handle of the host's node: the USB gateway's when the client talks
        through it, else the client's own (a fault on "the host's frames" acts on this one)."""
        return self.boards[_GATEWAY].can.bus if self.usb_port is not None else self.client.bus

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
                         "gains_source": g["source"], **{k: v for k, v in g.items() if k != "source"},
                         "safety": dataclasses.asdict(b.safety)}
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
            # ISO 11898-1 fault confinement per node (bus/network.py): TEC/REC, state,
            # retransmissions, bus-off count, frames lost to injected loss (issue 11)
            "error_counters": self._error_counters_snapshot or self._named_error_counters(),
        }

    def _named_error_counters(self) -> dict:
        """The bus model's per-node fault-confinement counters (TEC/REC, state, retransmissions,
        bus-off count, frames lost), keyed by board name; ``host`` for the host's own CAN handle
        when it has one (a direct host, e.g. serve's monitor)."""
        out = {}
        handles = [(name, b.can.bus) for name, b in self.boards.items() if getattr(b, "can", None) is not None]
        if not isinstance(self.client.bus, HidGatewayBus):
            handles.append(("host", self.client.bus))
        for name, bus in handles:
            try:
                out[name] = self.network.error_state(bus).as_dict()
            except Exception:  # noqa: BLE001 - a handle not on this network (closed or foreign)
                continue
        return out

    def board_summary(self) -> dict:
        """One row per board (registry order): node, counters, state; each board adds its own
        counters through ``report_counters()``."""
        out = {}
        for name, b in self.boards.items():
            d = {"node": b.node_id, "malformed_frames": b.malformed_frames,
                 # the host's view first: a board whose heartbeat stopped is LOST whatever it was
                 "state": "LOST" if b.node_id in self.client.lost else b.status_name}
            if getattr(b, "device", None) is not None:       # a CANopen board (not the gateway)
                d["emcy_sent"] = b.device.emcy.sent
            d.update({"reset_cause": b.reset_cause, "resets": b.reset_count,
                      "can": self._can_snapshot.get(name) or _can_registers(b)})
            d.update(b.report_counters())
            if name == _GATEWAY and self.usb_port is not None:   # the PC's side of the USB link
                d["usb_host"] = self.usb_port.counters()
            if BOARDS[name][0].kind == "focus_controller":   # the plant's truth beside the firmware's count
                d["plant_lost_halfsteps"] = self.focus_plant.lost_halfsteps
            if b.uart is not None:
                d["telemetry_packets_sent"] = b.uart.tx_writes
                d["telemetry_late_writes"] = b.uart.tx_late
            out[name] = d
        return out

    def room_summary(self) -> dict | None:
        """Issue 12: the dome plant and the weather the station measured, when those boards ran
        (None otherwise); read from the plant objects."""
        out = {}
        if "dome" in self.boards:
            d = self.dome_plant
            out["dome"] = {"azimuth_deg": round(d.azimuth_deg % 360.0, 3),
                           "peak_rate_deg_s": round(d.peak_rate_deg_s, 4),
                           "max_rate_deg_s": self.boards["dome"].max_rate_deg_s,
                           "acceleration_deg_s2": self.boards["dome"].acceleration_deg_s2,
                           "latitude_deg": self.boards["dome"].latitude_deg}
        if "weather" in self.boards:
            w = self.weather
            out["weather"] = {"seed": w.seed, "events": len(w.events), "temperature_c": round(w.temperature_c, 2),
                              "humidity_pct": round(w.humidity_pct, 2), "wind_m_s": round(w.wind_m_s, 2),
                              "rain": w.rain}
        if "display" in self.boards:
            out["display"] = {"lines": self.display_log.lines, "last": self.display_log.last}
        return out or None

    def rs232_summary(self) -> dict | None:
        """Per-port telemetry counters of the hub (None when RS232 is off)."""
        return self.hub.counters() if self.hub is not None else None

    def close(self) -> None:
        """Shut every bus down and unregister the CAN channel (idempotent). The boards' CAN
        error registers are kept for the report (they live in the bus model)."""
        if not self._can_snapshot:
            self._can_snapshot.update({name: _can_registers(b) for name, b in self.boards.items()})
            if self.network is not None:
                self._error_counters_snapshot.update(self._named_error_counters())
        self.client.close()
        if self.display_log is not None:
            self.display_log.close()
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
_GATEWAY = next(name for name, (s, i) in BOARDS.items() if s.kind == GATEWAY_KIND)


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
    dome_plant: DomePlant | None = None
    weather: WeatherModel | None = None
    display_log: DisplayLog | None = None


#: Port name (a firmware keyword argument, ``BoardSpec.ports``) -> factory(build, instance) ->
#: the callable handed to the firmware. A new board kind that needs a plant quantity no board has
#: yet adds one factory here.
PORTS: dict[str, Callable[[_Build, BoardInstance], Callable]] = {
    "read_qei_counts": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, b.plants[i.axis].qei_counts),
    "on_duties": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, b.plants[i.axis].set_duties),
    "shunt_a_v": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, partial(b.plants[i.axis].shunt_voltage_v, "a")),
    "shunt_b_v": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, partial(b.plants[i.axis].shunt_voltage_v, "b")),
    "read_position_word": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, b.plants[i.axis].absolute_counts),
    "on_step": lambda b, i: PlantPort(b.focus_plant, b.scheduler, b.focus_plant.step),
    "on_power": lambda b, i: PlantPort(b.focus_plant, b.scheduler, b.focus_plant.set_power),
    # the kinematic focus plant changes only on step()/set_power(), so its read-only sensors
    # need no advance_to: direct ports (cheaper; sampled every 10 ms with RS232)
    "read_lvdt_v": lambda b, i: b.focus_plant.lvdt_voltage_v,
    "read_index": lambda b, i: b.focus_plant.at_index,
    "read_encoder_counts": lambda b, i: b.focus_plant.motor_encoder_counts,
    # -- issue 12, room nodes
    "on_show": lambda b, i: b.display_log.show,
    "read_azimuth_counts": lambda b, i: PlantPort(b.dome_plant, b.scheduler, b.dome_plant.encoder_counts),
    "set_speed_reference": lambda b, i: PlantPort(b.dome_plant, b.scheduler, b.dome_plant.set_speed_reference),
    "read_temperature_v": lambda b, i: PlantPort(b.weather, b.scheduler, b.weather.temperature_v),
    "read_humidity_v": lambda b, i: PlantPort(b.weather, b.scheduler, b.weather.humidity_v),
    "read_wind_v": lambda b, i: PlantPort(b.weather, b.scheduler, b.weather.wind_v),
    "read_rain": lambda b, i: PlantPort(b.weather, b.scheduler, lambda w=b.weather: w.rain),
    # issue 12: the CP-850 on motor a/b of the axis, the auxiliary encoder's 17-bit word
    "read_motor_counts": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, partial(b.plants[i.axis].tach_counts, i.motor)),
    "read_aux_word": lambda b, i: AxisPlantPort(b.plants[i.axis], b.scheduler, b.plants[i.axis].aux_encoder_word),
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


def _qei_counts_per_rev(ap) -> int:
    """Friction-roller encoder counts per axis revolution (§2.2: 4.608e6 ppr × 24.5), read by the
    axis controller's QEI and by the axis velocity reader."""
    return int(round(ap.encoders.incremental_counts_per_rev * ap.encoders.roller_ratio))


def _axis_settings(b: _Build, i: BoardInstance) -> dict:
    ap = b.params.axes[i.axis]
    cc = getattr(b.scenario.controller, i.axis)
    p = ap.drive.counter_fraction if cc.counter_fraction is None else cc.counter_fraction
    g = design_axis_gains(ap, p, TICK_US)
    gd = g.as_dict()
    b.gains[i.axis] = {"source": GAINS_SOURCE if cc.kp is None and cc.ki is None else "scenario override",
                       **{f"model_{k}": v for k, v in gd.items() if k not in ("kp", "ki")}}
    return dict(safety=b.scenario.safety_limits(), kp=g.kp if cc.kp is None else cc.kp, ki=g.ki if cc.ki is None else cc.ki,
                u_max=1.0 if cc.u_max is None else cc.u_max, counter_fraction=p, law=ap.drive.preload_law,
                qei_counts_per_rev=_qei_counts_per_rev(ap),
                shunt_ohm=ap.motor.shunt_ohm, overcurrent_a=ap.motor.rated_current_a)


#: Board kind -> settings(build, instance) -> extra firmware keyword arguments taken from the
#: parameter file and the scenario. Kinds without an entry take none.
def _dome_settings(b: _Build, i: BoardInstance) -> dict:
    d = b.params.dome
    return dict(latitude_deg=b.params.site.latitude_deg, max_rate_deg_s=d.max_rate_deg_s,
                acceleration_deg_s2=d.acceleration_deg_s2, deadband_deg=d.deadband_deg,
                park_azimuth_deg=d.park_azimuth_deg, vfd_full_scale_deg_s=d.vfd_full_scale_deg_s,
                encoder_counts_per_rev=d.encoder_counts_per_rev, dac_bits=d.dac_bits,
                control_period_us=d.control_period_us, position_timeout_us=d.position_timeout_us)


def _weather_settings(b: _Build, i: BoardInstance) -> dict:
    w = b.params.weather
    return dict(sample_period_us=w.sample_period_us, temperature_min_c=w.temperature_min_c,
                temperature_max_c=w.temperature_max_c, wind_full_scale_m_s=w.wind_full_scale_m_s,
                high_wind_limit_m_s=w.high_wind_limit_m_s, high_wind_clear_m_s=w.high_wind_clear_m_s,
                humidity_limit_pct=w.humidity_limit_pct, clear_hold_s=w.clear_hold_s)


SETTINGS: dict[str, Callable[[_Build, BoardInstance], dict]] = {
    "axis_controller": _axis_settings,
    "position_reader": lambda b, i: {"safety": b.scenario.safety_limits()},
    "focus_controller": lambda b, i: {"encoder_counts_per_rev": b.params.focus.motor_encoder_counts_per_rev},
    # -- issue 12, room nodes
    "display": lambda b, i: {"refresh_period_us": b.params.display.refresh_period_us,
                             "stale_timeout_us": b.params.display.stale_timeout_us},
    "dome": _dome_settings,
    "weather": _weather_settings,
    # issue 12: encoder resolutions from the parameter file (axes.<axis>.tachometer / .aux_encoder)
    "tachometer": lambda b, i: {"counts_per_rev": b.params.axes[i.axis].tachometer.counts_per_rev},
    "velocity_reader": lambda b, i: {"qei_counts_per_rev": _qei_counts_per_rev(b.params.axes[i.axis])},
    "aux_encoder": lambda b, i: {"bits": b.params.axes[i.axis].aux_encoder.bits,
                                 "reduction": b.params.axes[i.axis].aux_encoder.reduction},
}


def build_network(scenario: Scenario, host_cls: type[HostClient] = HostClient,
                  boards=None) -> Telescope:
    """Build clock, bus, plants, boards and host client for ``scenario`` (boards started).

    Parameters
    ----------
    scenario : Scenario
        What to build (``bus``, ``plant``, ``controller``, ``rs232``).
    host_cls : type
        The host node's class: :class:`host.client.HostClient` (default) or a subclass such as
        :class:`host.monitor.BusMonitor` (``schmidt-fil serve``: a passive monitor, so that a
        host program outside the emulator commands the boards).
    boards : iterable of str, optional
        Registry names of the boards to build (built in node order) instead of the scenario's
        ``network`` (``basic`` by default; :func:`boards.registry.network_boards`). The host's
        health check expects exactly the CANopen boards built.

    Returns
    -------
    Telescope
        On the ``sim`` bus, ``tel.network.channel`` is the channel a host of your own opens with
        ``can.Bus(interface="schmidt-sim", channel=...)`` (docs/serve.md).

    Raises
    ------
    ScenarioError
        Parameter file or overrides invalid.
    KeyError
        An unknown board name (the message lists the valid ones).
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

    # the scenario's seed seeds the plant's sensor noise (the auxiliary encoder, issue 12)
    plants = {axis: AxisPlant(params.axes[axis], name=axis, seed=scenario.seed) for axis in AXES}
    focus_plant = FocusPlant(params.focus)
    dome_plant = DomePlant(params.dome)
    ws = scenario.weather
    weather = WeatherModel(params.weather, scenario.seed if ws.seed is None else ws.seed,
                           [WeatherEvent(e.at_s, e.kind, e.duration_s, e.wind_m_s or 0.0) for e in ws.events])
    display_log = DisplayLog(lambda: sched.now_us)

    def plant_tick(now_us: int) -> None:
        for p in plants.values():
            p.advance_to(now_us)
        if dome_plant.rate_deg_s:
            dome_plant.advance_to(now_us)

    sched.call_every(PLANT_PERIOD_US, plant_tick, start_us=0, priority=PRIO_PLANT, owner="plant")

    # the boards of the scenario's network (boards.registry.NETWORKS; default basic), node order;
    # the host's own node, the USB-HID gateway, is on every network
    chosen = network_boards(scenario.network if boards is None else list(boards))
    network_name = scenario.network_name if boards is None else "custom"
    # the host's health check expects every chosen CANopen board (not the host's own node)
    expected = canopen_nodes(chosen, BOARDS)

    # a direct host first, so it hears the boards' boot heartbeats (through the gateway, the
    # gateway's CAN handle is made with the boards and started before them)
    via_gateway = getattr(host_cls, "THROUGH_GATEWAY", True) and _GATEWAY in chosen
    host_bus = None if via_gateway else new_bus()
    boards: dict = {}

    # RS232 telemetry: one point-to-point link per board that has it (bus.telemetry: the PI,
    # position and focus boards of the §3.4 set-up), the far ends on the host's hub
    rs = scenario.rs232
    hub = Rs232Hub(sched, rs.baud) if rs.enabled else None
    tlm_boards = [n for n in chosen if int(BOARDS[n][0].device_type) in T.SAMPLE_FIELDS]
    links = {name: SerialLink(sched, baud=rs.baud, name=f"rs232-{name}") for name in tlm_boards} if hub else {}

    build = _Build(scenario, sched, params, plants, focus_plant, {}, dome_plant, weather, display_log)
    for name in chosen:
        spec, inst = BOARDS[name]
        kwargs = {port: PORTS[port](build, inst) for port in spec.ports}
        kwargs.update(SETTINGS.get(spec.kind, lambda b, i: {})(build, inst))
        boards[name] = spec.firmware(sched, new_bus(), inst.node_id, name=name,
                                     serial_port=links[name].a if name in links else None, **kwargs)
    if hub is not None:
        for name in tlm_boards:
            hub.add_port(links[name].b, name, boards[name].node_id)
    gateway = boards.get(_GATEWAY)
    if via_gateway:
        gateway.start()        # first, so that it hears the boards' boot-up messages
    for b in boards.values():
        if b is not gateway:
            b.start()
    usb_port = None
    if via_gateway:
        # the PC's USB host: the client reads inside scheduler callbacks (advance=None) and is
        # woken by each IN report (no poll event of its own)
        usb = hid_device.SimUsb()
        usb_port = usb.plug(gateway, advance=None)
        dev = hid_device.device(usb=usb)
        dev.open(VENDOR_ID, PRODUCT_ID)
        host_bus = HidGatewayBus(dev)
        buses.append(host_bus)

    adc = Adc({})
    shunt = params.axes["ra"].motor.shunt_ohm
    # the setpoints the host reports are the presets the axis firmware holds now (0x2001 is rw)
    preset = _LivePresets(boards)
    client = host_cls(
        bus=host_bus, scheduler=sched, preset_rates_arcsec_s=preset, expected_nodes=expected,
        # the duty-speed map with the counter fraction the axis firmware runs
        open_loop_duty=lambda rate, axis: open_loop_duty(rate, params.axes[axis],
                                                         boards[_AXIS_BOARD[axis]].counter_fraction),
        adc_to_current_a=AdcCurrent(adc, shunt),
        arcsec_per_count={axis: boards[_AXIS_BOARD[axis]].arcsec_per_count for axis in AXES},
    )
    # issue 12: resolutions of the tachometers and auxiliary encoders that run (maintenance quantities)
    client.configure_maintenance(
        tach_counts_per_rev={int(b.node_id): b.counts_per_rev for n, b in boards.items()
                             if BOARDS[n][0].kind == "tachometer"},
        aux_arcsec_per_count={int(b.node_id): b.arcsec_per_count for n, b in boards.items()
                              if BOARDS[n][0].kind == "aux_encoder"})
    return Telescope(scenario=scenario, scheduler=sched, params=params, network=network, plants=plants,
                     focus_plant=focus_plant, boards=boards, client=client, gains=build.gains, buses=buses,
                     hub=hub, serial_links=links, dome_plant=dome_plant, weather=weather,
                     display_log=display_log, network_name=network_name, usb_port=usb_port)
