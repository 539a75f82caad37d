"""Build the emulated telescope network from a scenario: the ONE place where boards, bus and
plant are wired together.

Boards never see plant objects: each peripheral gets a *port* (a callable) built here —
PWM duty → motor voltages, shaft angle → QEI counts / EnDat position word, armature current →
shunt voltage → ADC. The plants are advanced lazily to the scheduler's time by every port and
also by a 5 ms plant event on the same clock (so the plant keeps moving when a board is reset
or removed).

Decisions written down here:

* **Gains** come from :func:`boards.tuning.pi_gains_from_model` with the axis parameters of the
  loaded parameter file and the **low-preload** friction set: the paper tuned its PI for the
  reduced-preload model (§4 "Using the estimated parameters …") and kept the gains ("we preferred
  keeping the gains high"); running the high-preload scenario with the same controller is what
  Fig. 13(a)/(b) compare. A scenario may override ``kp``/``ki``.
* **Open-loop duty** (the operator's duty–speed map for the open-loop runs of §4): the steady
  state of the motor equations with the LuGre static curve (the torque–velocity map of Fig. 8):
  ``N K/R ((1−p) d V − 2 K N ω) = Tc + (Ts−Tc) exp(−(ω/ωs)^δ) + σ2 ω``, solved for the duty d.
  The counter motor is back-driven and brakes (the ``2 K N ω`` term; both motors' back-EMF).
* **RS232 telemetry** (§3.4, scenario ``rs232``): one :class:`bus.serial_link.SerialLink` per
  board at the scenario's baud (8N1); the board's end goes to its firmware's ``serial_port``
  (its UART), the other end to the host's :class:`host.rs232.Rs232Hub`, which is woken by the
  link's receive callback once per packet (no per-byte or per-sample events).
* **Focus encoder**: the focus firmware's QEI reads ``FocusPlant.motor_encoder_counts`` and is
  told the parameter file's counts per revolution.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import can

import bus as _bus_pkg  # noqa: F401  (registers the schmidt-sim python-can interface)
from boards.axis_controller import PRESET_RATES_ARCSEC_S, AxisController, AxisMode
from boards.focus_controller import FocusController
from boards.peripherals import Adc
from boards.position_reader import PositionReader
from boards.tuning import pi_gains_from_model
from bus import protocol as P
from bus.network import CanNetwork
from bus.scheduler import PRIO_PLANT, Scheduler
from bus.serial_link import SerialLink
from host.client import HostClient
from host.rs232 import Rs232Hub
from host.scenario import Scenario, ScenarioError
from plant.axis import AxisPlant
from plant.focus import FocusPlant
from plant.params import ParameterError, PlantParameters, load_parameters

__all__ = ["Telescope", "build_network", "resolve_parameters", "open_loop_duty", "BOARD_NAMES"]

#: Board names (scenario ``faults[].board``) in node order.
BOARD_NAMES = ("ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus")
#: Plant keep-alive period [µs]: every port advances the plant to the current time before it
#: reads or writes, so the plant is exact at each ISR; this event only keeps it moving when no
#: board touches it (a board reset or removed), and bounds the lazy catch-up.
PLANT_PERIOD_US = 50_000
ARCSEC_PER_RAD = 648_000.0 / math.pi
_unique = itertools.count(1)


def resolve_parameters(scenario: Scenario) -> PlantParameters:
    """Load the scenario's plant parameter file with its overrides.

    Raises
    ------
    ScenarioError
        The parameter file is missing or an override names an unknown parameter (the message
        names the scenario file and the ``plant.overrides`` key).
    """
    pc = scenario.plant
    path = None
    if pc.parameter_file:
        path = Path(pc.parameter_file)
        if not path.is_absolute():
            path = Path(scenario.source_path).parent / path
        if not path.exists():
            raise ScenarioError(scenario.source_path, None, "plant.parameter_file", f"file not found: {path}")
    overrides: dict = {}
    if pc.preload is not None:
        overrides["axes.ra.friction.preload"] = pc.preload
        overrides["axes.dec.friction.preload"] = pc.preload
    if pc.perfect is not None:
        overrides["perfect"] = pc.perfect
    overrides.update(pc.overrides)
    try:
        return load_parameters(path, overrides or None)
    except ParameterError as exc:
        key = next((k for k in pc.overrides if k in str(exc)), None)
        raise ScenarioError(scenario.source_path, None, f"plant.overrides.{key}" if key else "plant", str(exc)) from None


def open_loop_duty(rate_arcsec_s: float, axis_params, counter_fraction: float | None = None) -> float:
    """Duty that holds ``rate_arcsec_s`` in steady state by the model's duty–speed map.

    Parameters
    ----------
    rate_arcsec_s : float
        Target axis rate magnitude [arcsec/s].
    axis_params : plant.params.AxisParameters
        The axis (motor, gear, drive, active friction set).
    counter_fraction : float, optional
        p of the drive law; default the parameter file's.

    Returns
    -------
    float
        Forward-motor duty (0..1, clipped).
    """
    m, g, fr = axis_params.motor, axis_params.gear, axis_params.friction
    fs = getattr(fr, fr.preload)
    p = axis_params.drive.counter_fraction if counter_fraction is None else counter_fraction
    w = abs(rate_arcsec_s) / ARCSEC_PER_RAD
    t_fric = fs.tc_nm + (fs.ts_nm - fs.tc_nm) * math.exp(-((w / fs.omega_s_rad_s) ** fr.delta)) + fs.sigma2_nm_s_rad * w
    n, k, r = g.ratio, m.torque_constant_nm_a, m.resistance_ohm
    t_fric += 2 * m.viscous_nm_s_rad * n * n * w  # motor bearing drag of both motors, reflected
    v = (t_fric * r / (n * k) + 2 * k * n * w) / (1.0 - p)
    return max(0.0, min(1.0, v / m.supply_v))


@dataclass
class Telescope:
    """The built network: clock, CAN bus, plants, boards and host client."""

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

    def advance_plants(self, now_us: int | None = None) -> None:
        """Advance every plant to ``now_us`` (default the scheduler's time)."""
        t = self.scheduler.now_us if now_us is None else now_us
        for p in self.plants.values():
            p.advance_to(t)
        self.focus_plant.advance_to(t)

    # -- fault injection -------------------------------------------------------------------
    def inject_fault(self, fault, now_us: int) -> None:
        """Apply one scenario fault (see :class:`host.scenario.Fault`)."""
        board = self.boards[fault.board]
        if fault.kind == "endat_bit_flip":
            if not isinstance(board, PositionReader):
                raise ScenarioError(self.scenario.source_path, None, "faults", f"endat_bit_flip needs a reader board, not {fault.board}")
            board.endat.flip_bit(fault.bit if fault.bit is not None else 0)
        elif fault.kind == "malformed_frame":
            node = board.node_id
            cob = P.axis_command_cob_id(node) if node in P.AXIS_NODES else (
                P.focus_command_cob_id() if node == P.NODE_FOCUS else P.host_broadcast_cob_id())
            # a frame with the wrong device type byte and a short DLC: the board must count it
            self.client.send_raw(cob, bytes([0xEE, 0x42, 0x00]), fault.board)
        elif fault.kind == "board_reset":
            board.reset("watchdog")  # a running board boots again by itself
        elif fault.kind == "remove_board":
            board.power_off()  # firmware stops, no frames; the host notices missing heartbeats
            self.removed.add(fault.board)
        elif fault.kind == "focus_stall":
            self.focus_plant.advance_to(now_us)
            self.focus_plant.stall(fault.halfsteps)  # the plant loses steps; the firmware must notice
        if self.client.logs:
            self.client.logs.error(now_us, fault.board, "injected-fault", fault.kind)

    # -- summaries for the report --------------------------------------------------------------
    def controller_summary(self) -> dict:
        out = {}
        for axis, b in (("ra", self.boards["ra-axis"]), ("dec", self.boards["dec-axis"])):
            g = self.gains[axis]
            out[axis] = {"kp_duty_per_arcsec_s": b.kp0, "ki_duty_per_arcsec_s_tick": b.ki0,
                         "u_max": b.u_max, "counter_fraction": b.counter_fraction, "drive_law": b.law_name,
                         "gains_source": g["source"], **{k: v for k, v in g.items() if k != "source"}}
        return out

    def plant_summary(self) -> dict:
        out = {"perfect": self.params.perfect}
        for axis, p in self.plants.items():
            ap = self.params.axes[axis]
            fs = getattr(ap.friction, ap.friction.preload)
            out[axis] = {
                "preload": ap.friction.preload, "sigma2_nm_s_rad": fs.sigma2_nm_s_rad, "tc_nm": fs.tc_nm,
                "ts_nm": fs.ts_nm, "omega_s_rad_s": fs.omega_s_rad_s, "sigma0_nm_rad": ap.friction.sigma0_nm_rad,
                "sigma1_nm_s_rad": ap.friction.sigma1_nm_s_rad, "inertia_kg_m2": ap.inertia_kg_m2,
                "drive_model": ap.drive_model, "max_substep_us": ap.max_substep_us,
                "peak_current_a": [round(float(i), 3) for i in p.peak_current_a],
                "time_over_rating_s": [round(t / 1e6, 3) for t in p.current_over_rating_us],
                "effects": [e.get("kind") if isinstance(e, dict) else getattr(e, "kind", str(e)) for e in ap.effects],
            }
        return out

    def bus_stats(self) -> dict:
        if self.network is None:
            return {"interface": self.scenario.bus.interface, "note": "no bit timing on this bus"}
        s = self.network.stats()
        return {
            "interface": "sim", "bitrate": self.network.bitrate, "frames": s["frames"], "bits": s["bits"],
            "load_pct": round(s["load_pct"], 3), "peak_load_pct": round(s["peak_load_pct"], 3),
            "max_latency_us": {P.frame_name(k): v for k, v in s["max_latency_us"].items()},
            "frames_by_id": {P.frame_name(k): v for k, v in s["per_id"].items()},
        }

    def board_summary(self) -> dict:
        out = {}
        for name, b in self.boards.items():
            d = {"node": b.node_id, "malformed_frames": b.malformed_frames, "state": _state_name(b),
                 "reset_cause": b.reset_cause, "resets": b.reset_count}
            if isinstance(b, PositionReader):
                d["crc_errors"] = b.endat.crc_errors
            if isinstance(b, FocusController):
                d["missed_steps"] = b.missed_steps
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
        """Shut every bus down and unregister the CAN channel (idempotent)."""
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


def _state_name(board) -> str:
    try:
        return P.NodeState(board.state).name
    except (ValueError, TypeError):
        return str(board.state)


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

    plants = {axis: AxisPlant(params.axes[axis], name=axis) for axis in ("ra", "dec")}
    focus_plant = FocusPlant(params.focus)

    def plant_tick(now_us: int) -> None:
        for p in plants.values():
            p.advance_to(now_us)

    sched.call_every(PLANT_PERIOD_US, plant_tick, start_us=0, priority=PRIO_PLANT, owner="plant")

    # host first, so it hears the boards' boot heartbeats
    adc = Adc({})
    shunt = params.axes["ra"].motor.shunt_ohm
    preset = {(AxisMode.NAMES[m].lower(), axis): rates[i] for m, rates in PRESET_RATES_ARCSEC_S.items()
              for i, axis in enumerate(("ra", "dec"))}
    client = host_cls(
        bus=new_bus(), scheduler=sched, preset_rates_arcsec_s=preset,
        open_loop_duty=lambda rate, axis: open_loop_duty(rate, params.axes[axis]),
        adc_to_current_a=lambda c: adc.to_volts(c) / shunt,
    )

    # RS232 telemetry: one point-to-point link per board, the far ends on the host's hub
    rs = scenario.rs232
    hub = Rs232Hub(sched, rs.baud) if rs.enabled else None
    links = {name: SerialLink(sched, baud=rs.baud, name=f"rs232-{name}") for name in BOARD_NAMES} if hub else {}

    def board_port(name: str):
        return links[name].a if links else None

    boards: dict = {}
    gains: dict = {}
    for i, axis in enumerate(("ra", "dec")):
        ap, plant = params.axes[axis], plants[axis]
        cc = getattr(scenario.controller, axis)
        p = ap.drive.counter_fraction if cc.counter_fraction is None else cc.counter_fraction
        g = pi_gains_from_model(
            inertia_kg_m2=ap.inertia_kg_m2, sigma2_nm_s_rad=ap.friction.low.sigma2_nm_s_rad,
            gear_ratio=ap.gear.ratio, r_ohm=ap.motor.resistance_ohm, l_h=ap.motor.inductance_h,
            k_nm_a=ap.motor.torque_constant_nm_a, rotor_inertia_kg_m2=2 * ap.motor.rotor_inertia_kg_m2,  # both rotors turn with the axis
            counter_fraction=p, supply_v=ap.motor.supply_v, tick_us=5_000,
        )
        gd = g.as_dict()
        gains[axis] = {"source": "boards.tuning.pi_gains_from_model (SIMC on the eq. 6 SOPDT model, low-preload σ2)"
                       if cc.kp is None and cc.ki is None else "scenario override",
                       **{f"model_{k}": v for k, v in gd.items() if k not in ("kp", "ki")}}

        def read_qei(plant=plant) -> int:
            plant.advance_to(sched.now_us)
            return plant.qei_counts()

        def on_duties(a: float, b: float, plant=plant) -> None:
            plant.advance_to(sched.now_us)
            plant.set_duties(a, b)

        def shunt_v(motor: str, plant=plant) -> float:
            plant.advance_to(sched.now_us)
            return plant.shunt_voltage_v(motor)

        def read_abs(plant=plant) -> int:
            plant.advance_to(sched.now_us)
            return plant.absolute_counts()

        boards[f"{axis}-axis"] = AxisController(
            sched, new_bus(), P.AXIS_NODES[i], read_qei_counts=read_qei, on_duties=on_duties,
            shunt_a_v=lambda s=shunt_v: s("a"), shunt_b_v=lambda s=shunt_v: s("b"),
            kp=g.kp if cc.kp is None else cc.kp, ki=g.ki if cc.ki is None else cc.ki,
            u_max=1.0 if cc.u_max is None else cc.u_max, counter_fraction=p, law=ap.drive.preload_law,
            qei_counts_per_rev=int(round(ap.encoders.incremental_counts_per_rev * ap.encoders.roller_ratio)),
            shunt_ohm=ap.motor.shunt_ohm, overcurrent_a=ap.motor.rated_current_a,
            serial_port=board_port(f"{axis}-axis"),
        )
        boards[f"{axis}-reader"] = PositionReader(sched, new_bus(), P.READER_NODES[i], read_position_word=read_abs,
                                                  serial_port=board_port(f"{axis}-reader"))

    def focus_port(fn):
        def port(*a):
            focus_plant.advance_to(sched.now_us)
            return fn(*a)
        return port

    boards["focus"] = FocusController(
        sched, new_bus(), P.NODE_FOCUS, on_step=focus_port(focus_plant.step),
        read_lvdt_v=focus_plant.lvdt_voltage_v, read_index=focus_plant.at_index,
        on_power=focus_port(focus_plant.set_power),
        # the kinematic focus plant changes only on step()/set_power(), so its read-only sensors
        # need no advance_to: direct ports (cheaper; sampled every 10 ms with RS232)
        read_encoder_counts=focus_plant.motor_encoder_counts,
        encoder_counts_per_rev=params.focus.motor_encoder_counts_per_rev,
        serial_port=board_port("focus"),
    )
    boards = {name: boards[name] for name in BOARD_NAMES}
    if hub is not None:
        for name in BOARD_NAMES:
            hub.add_port(links[name].b, name, boards[name].node_id)
    for b in boards.values():
        b.start()
    return Telescope(scenario=scenario, scheduler=sched, params=params, network=network, plants=plants,
                     focus_plant=focus_plant, boards=boards, client=client, gains=gains, buses=buses,
                     hub=hub, serial_links=links)
