"""Fuzzing the boards with random and adversarial frames, in simulated time (issue 11).

:func:`run_fuzz` builds the full emulated telescope (five boards, both axis plants, the focus
plant) from a minimal scenario, puts the RA and DEC axes close to their high soft limits, and
feeds frames from :class:`FrameGenerator`:

* through the bus, from a fuzzer node (valid CAN 2.0A data frames: they arbitrate, occupy the
  wire and pass the boards' acceptance filters like any frame), about 3 per ms of simulated time
  (with the boards' own traffic ≈ 80 % bus load);
* directly into a powered board's CAN receive path (``CanController.on_rx``), about 7 per ms:
  frames the bus refuses to carry (extended, remote, error, more than 8 data bytes) and frames
  on identifiers the acceptance filter would drop.

Half the frames are uniformly random (identifier, DLC, bytes); half are adversarial: the
boards' own identifiers and layouts with extreme or boundary values (gains 0 and 2**31 − 1,
rates beyond slew, duties beyond ±1, focus targets beyond travel, spoofed LIMIT frames,
broadcast RESET/STOP_ALL, wrong DLC or device type).

The fuzzer commands SLEW toward the high limits at the start of each block of ``stop_every``
frames and leaves AXIS_COMMAND out of the adversarial mix for the first half of the block, so
the axes run into their soft limits under all other traffic (spoofed LIMIT and POSITION frames,
broadcasts, focus commands, random identifiers). Every ``stop_every`` frames the fuzzer sends STOP_ALL (0x190) and measures, on the plant
(not on what the firmware reports), the time until both axes are below
``STANDSTILL_ARCSEC_S``; fuzzing resumes after that. Reported: frames sent, exceptions raised by
the emulator (must be 0), non-finite values seen in the plants' states and the boards' control
variables (must be 0), the largest soft-limit overshoot per axis (plant angle beyond the
reader's limit) and the highest angle reached, the longest STOP-to-standstill time, and the
FAULT frames seen on the wire by code (cumulative; the boards' own counters restart at each
reset the fuzzer causes).
"""

from __future__ import annotations

import math
import random
import time
from dataclasses import asdict, dataclass, field

import can

from bus import protocol as P
from bus.units import ARCSEC_PER_RAD

__all__ = ["FrameGenerator", "FuzzResult", "run_fuzz", "STANDSTILL_ARCSEC_S"]

#: An axis counts as at standstill below this rate, ″/s (= boards/safety.py
#: ``brake_stop_tol_arcsec_s``, the firmware's own notion of "stopped").
STANDSTILL_ARCSEC_S = 50.0
#: Give up waiting for standstill after this long, µs (counted in ``stop_timeouts``).
STOP_TIMEOUT_US = 5_000_000

_SCENARIO = """\
name: fuzz
seed: {seed}
plant: {{preload: low}}
faults: []
segments:
  - {{name: fuzz, axis: ra, mode: stop, duration_s: 1}}
"""

_I32 = (-(1 << 31), -1, 0, 1, (1 << 31) - 1)

#: Reader objects the fuzzer reads but never writes by SDO: the soft limits (0x2100) and the
#: encoder offset (0x2101). Writing them moves the limits or the position the limits are
#: checked against, by design (the alignment console, paper §5.2), so the soft-limit overshoot
#: measured against the packaged limits would no longer mean "the axis did not stop"; their
#: range checks are tested in tests/test_canopen_*.py.
ALIGNMENT_OBJECTS = (0x2100, 0x2101)


class FrameGenerator:
    """Random and adversarial frames for every board, reproducible from ``seed``.

    :meth:`next` returns ``(msg, via_bus)``: ``via_bus`` is True for a frame the emulated bus
    can carry (11-bit data frame, ≤ 8 bytes) chosen to go over the wire, False for one to inject
    directly into a board's receive path.
    """

    #: identifiers the boards accept, from the protocol's COB-ID functions
    #: (NMT 0x000 is left out: a random NMT stop/reset would end the run's motion by design)
    TARGET_IDS = (P.stop_all_cob_id(), P.axis_command_cob_id(1), P.axis_command_cob_id(2),
                  P.focus_command_cob_id(), P.limit_cob_id(3), P.limit_cob_id(4),
                  P.position_cob_id(3), P.position_cob_id(4), P.heartbeat_cob_id(0x10),
                  P.sdo_request_cob_id(1), P.sdo_request_cob_id(3), P.sdo_request_cob_id(5))

    _NO_AXIS_CMD = tuple(i for i in TARGET_IDS
                         if i not in (P.axis_command_cob_id(1), P.axis_command_cob_id(2)))

    def __init__(self, seed: int = 0, bus_fraction: float = 0.3) -> None:
        self.rng = random.Random(seed)
        self.bus_fraction = bus_fraction

    def _value(self) -> int:
        r = self.rng
        k = r.random()
        if k < 0.3:
            return r.choice(_I32)
        if k < 0.6:
            return r.randint(-(1 << 31), (1 << 31) - 1)
        return r.randint(-20_000_000, 20_000_000)

    def _adversarial(self, axis_commands: bool = True) -> can.Message:
        r = self.rng
        aid = r.choice(self.TARGET_IDS if axis_commands else self._NO_AXIS_CMD)
        b = bytearray(8)
        b[0] = r.choice((1, 2, 3, 0x10, r.randint(0, 255)))
        if aid in (P.axis_command_cob_id(1), P.axis_command_cob_id(2)):
            b[0] = 0x10 if r.random() < 0.9 else b[0]        # commands come from the host
            b[1] = r.randint(0, 12)
            b[2] = r.choice((1, 0xFF, 0, 0x7F, 0x80))
            b[4:8] = (self._value() & 0xFFFFFFFF).to_bytes(4, "little")
        elif aid == P.focus_command_cob_id():
            b[0] = 0x10 if r.random() < 0.9 else b[0]
            b[1] = r.randint(0, 6)
            b[4:8] = (self._value() & 0xFFFFFFFF).to_bytes(4, "little")
        elif aid == P.stop_all_cob_id():
            b[0] = 0x10
            # mostly a wrong command byte; a valid STOP_ALL rare enough that the axes get moving
            b[1] = r.choices((3, r.randint(0, 255)), weights=(5, 95))[0]
            b[2] = r.choice((0, 1, 2, 3, 4, 5, r.randint(0, 255)))
            b[3] = r.randint(0, 3)
        elif P.FC_SDO_RX < aid < P.FC_SDO_RX + 0x80:
            # SDO requests: uploads/downloads of real and unknown objects, random payloads
            b[0] = r.choice((0x40, 0x23, 0x2B, 0x2F, 0x60, 0x80, r.randint(0, 255)))
            b[1:3] = r.choice((0x1000, 0x1018, 0x2000, 0x2001, 0x2100, 0x2200, 0x2F00,
                               r.randint(0, 0xFFFF))).to_bytes(2, "little")
            b[3] = r.randint(0, 5)
            b[4:8] = bytes(r.randint(0, 255) for _ in range(4))
            if int.from_bytes(b[1:3], "little") in ALIGNMENT_OBJECTS and b[0] & 0xE0 == 0x20:
                b[0] = 0x40     # read, never write, the soft limits and encoder offset (see below)
        elif aid in (P.limit_cob_id(3), P.limit_cob_id(4)):
            b[0] = 2
            b[1] = r.randint(0, 2)
            b[2] = r.randint(0, 8)
            b[4:8] = r.randint(0, (1 << 32) - 1).to_bytes(4, "little")
        else:   # POSITION spoofs and host heartbeats
            b[0] = r.choice((2, 0x10, b[0]))
            b[1:8] = bytes(r.randint(0, 255) for _ in range(7))
        dlc = 8 if r.random() < 0.9 else r.randint(0, 8)
        return can.Message(arbitration_id=aid, data=bytes(b[:dlc]), is_extended_id=False)

    def next(self, axis_commands: bool = True) -> tuple[can.Message, bool]:
        """The next frame and whether it goes over the bus (``axis_commands=False``: no
        adversarial AXIS_COMMAND frames, so a commanded slew runs into the limit)."""
        r = self.rng
        k = r.random()
        if k < 0.45:
            msg = self._adversarial(axis_commands)
        elif k < 0.9:
            n = r.randint(0, 8)
            msg = can.Message(arbitration_id=r.randint(0, 0x7FF), is_extended_id=False,
                              data=bytes(r.randint(0, 255) for _ in range(n)))
        else:   # frames the bus does not carry: only by direct injection
            kind = r.randint(0, 3)
            aid = r.choice(self.TARGET_IDS)
            if kind == 0:
                msg = can.Message(arbitration_id=r.randint(0, 0x1FFFFFFF), is_extended_id=True,
                                  data=bytes(8))
            elif kind == 1:
                msg = can.Message(arbitration_id=aid, is_extended_id=False, is_remote_frame=True,
                                  dlc=r.randint(0, 8))
            elif kind == 2:
                msg = can.Message(arbitration_id=aid, is_extended_id=False, is_error_frame=True)
            else:
                msg = can.Message(arbitration_id=aid, is_extended_id=False, check=False,
                                  data=bytes(r.randint(0, 255) for _ in range(r.randint(9, 64))))
            return msg, False
        return msg, r.random() < self.bus_fraction


@dataclass
class FuzzResult:
    """Figures of one fuzz run (``--json`` prints :meth:`as_dict`)."""

    seed: int
    frames_sent: int = 0
    frames_via_bus: int = 0
    frames_direct: int = 0
    exceptions: int = 0
    exception_messages: list = field(default_factory=list)
    non_finite: int = 0
    overshoot_arcsec: dict = field(default_factory=lambda: {"ra": 0.0, "dec": 0.0})
    stop_trials: int = 0
    stop_to_standstill_max_ms: float = 0.0
    stop_timeouts: int = 0
    malformed_frames: dict = field(default_factory=dict)
    refused_commands: dict = field(default_factory=dict)
    board_resets: dict = field(default_factory=dict)
    fault_frames: dict = field(default_factory=dict)
    max_angle_deg: dict = field(default_factory=lambda: {"ra": -180.0, "dec": -180.0})
    simulated_s: float = 0.0
    wall_s: float = 0.0

    def as_dict(self) -> dict:
        return asdict(self)


def _finite_state(tel) -> bool:
    for p in tel.plants.values():
        if not all(math.isfinite(x) for x in p.state()):
            return False
    for name in ("ra-axis", "dec-axis"):
        ax = tel.boards[name]
        if not all(math.isfinite(x) for x in (ax.u, ax.setpoint_arcsec_s, ax.omega_arcsec_s,
                                               ax.kp, ax.ki, ax.brake_sp)):
            return False
    return True


def run_fuzz(frames: int, seed: int = 0, *, stop_every: int = 20_000,
             start_deg: tuple = (93.0, 108.0), progress=None) -> FuzzResult:
    """Send ``frames`` fuzz frames at the emulated telescope and measure what matters.

    Parameters
    ----------
    frames : int
        Frames to send (> 0).
    seed : int
        Seeds the frame generator and the scenario (same seed, same run).
    stop_every : int
        Frames between two STOP_ALL standstill measurements.
    start_deg : (float, float)
        Initial RA and DEC axis angles, degrees (default: near the high soft limits, so random
        motion commands run into them).
    progress : callable, optional
        ``progress(frames_sent)`` every 10 000 frames.

    Returns
    -------
    FuzzResult
    """
    from host.network import build_network
    from host.scenario import parse_scenario
    from bus.simbus import SimBus

    if frames <= 0:
        raise ValueError(f"--frames must be > 0, got {frames}")
    res = FuzzResult(seed=seed)
    gen = FrameGenerator(seed)
    rng = random.Random(seed + 1)
    tel = build_network(parse_scenario(_SCENARIO.format(seed=int(seed)), "<fuzz>"))
    wall0 = time.perf_counter()
    try:
        for axis, deg in zip(("ra", "dec"), start_deg):
            tel.plants[axis].reset(math.radians(deg))
        fuzzer = SimBus(network=tel.network, name="fuzzer")
        # STOP_ALL and SLEW go from a node of their own: behind the fuzzer's own FIFO they would
        # measure the fuzzer's queue, not the boards
        commander = SimBus(network=tel.network, name="fuzz-host")
        fault_ids = {P.emcy_cob_id(b.node_id) for b in tel.boards.values()
                     if b.CANOPEN_KIND}      # not the USB gateway: it sends no EMCY

        def count_faults(msg) -> None:     # EMCY frames on the wire, by fault code (cumulative)
            if msg.arbitration_id in fault_ids and len(msg.data) == 8:
                code = msg.data[3] if msg.data[0] or msg.data[1] else int(P.FaultCode.FAULT_CLEARED)
                name = P.FaultCode(code).name if code in P.FaultCode._value2member_map_ else str(code)
                res.fault_frames[name] = res.fault_frames.get(name, 0) + 1
        tel.network.add_tap(count_faults)
        sched = tel.scheduler
        boards = list(tel.boards.values())
        readers = {"ra": tel.boards["ra-reader"], "dec": tel.boards["dec-reader"]}
        sent = 0
        next_stop = stop_every
        block0 = 0
        # the boards boot PRE-OPERATIONAL: the host's NMT start first (docs/canopen.md)
        commander.send(can.Message(arbitration_id=P.nmt_cob_id(), is_extended_id=False,
                                   data=P.encode_nmt(P.NmtCommand.START)))
        _slew_all(commander)
        # a live host: the commander's CiA heartbeat every second keeps the axes' host watchdog
        # (2 s, boards/safety.py) fed, so the slews run into the limits under the fuzz traffic
        hb = can.Message(arbitration_id=P.heartbeat_cob_id(P.NODE_HOST), is_extended_id=False,
                         data=P.encode_heartbeat(P.NodeState.OPERATIONAL))
        sched.call_every(1_000_000, lambda now_us: commander.send(hb), start_us=sched.now_us,
                         owner="fuzz-host-heartbeat")
        while sent < frames:
            try:
                # first half of each block: the axes slew toward their high limits while every
                # other kind of adversarial frame keeps coming; second half: everything
                slewing = sent - block0 < stop_every // 2
                for _ in range(10):
                    msg, via_bus = gen.next(axis_commands=not slewing)
                    if via_bus:
                        fuzzer.send(msg)
                        res.frames_via_bus += 1
                    else:
                        b = boards[rng.randrange(len(boards))]
                        if b.started and b.can.on_rx is not None:
                            b.can.on_rx(msg)
                        res.frames_direct += 1
                    sent += 1
                sched.run_until(sched.now_us + 1_000)
                tel.advance_plants()
                if sent >= next_stop:
                    next_stop += stop_every
                    block0 = sent
                    _measure_stop(tel, commander, res)
                    _slew_all(commander)
            except Exception as exc:      # an emulator exception is the finding: count, stop
                res.exceptions += 1
                res.exception_messages.append(f"{type(exc).__name__}: {exc}"[:300])
                break
            if not _finite_state(tel):
                res.non_finite += 1
            for axis, rd in readers.items():
                p = tel.plants[axis]
                deg = math.degrees(p.axis_angle_rad)
                if deg > res.max_angle_deg[axis]:
                    res.max_angle_deg[axis] = deg
                over = max(deg - rd.high_limit_deg, rd.low_limit_deg - deg, 0.0) * 3600.0
                if over > res.overshoot_arcsec[axis]:
                    res.overshoot_arcsec[axis] = over
            if progress is not None and sent % 10_000 == 0:
                progress(sent)
        res.frames_sent = sent
        res.simulated_s = sched.now_us / 1e6
        for name, b in tel.boards.items():
            # board counters restart at each reset: these are since the last one
            res.malformed_frames[name] = b.malformed_frames
            res.refused_commands[name] = getattr(b, "refused_commands", 0)   # 0: the gateway
            res.board_resets[name] = b.reset_count
    finally:
        tel.close()
    res.wall_s = time.perf_counter() - wall0
    return res


def _slew_all(fuzzer) -> None:
    """SLEW + to both axes (toward their high soft limits)."""
    for node in P.AXIS_NODES:
        fuzzer.send(can.Message(arbitration_id=P.axis_command_cob_id(node), is_extended_id=False,
                                data=P.encode_axis_command(P.AxisCommand.SLEW, 1, 0)))


def _measure_stop(tel, fuzzer, res: FuzzResult) -> None:
    """STOP_ALL now; time until both axes (plant truth) are below STANDSTILL_ARCSEC_S."""
    sched = tel.scheduler
    fuzzer.send(can.Message(arbitration_id=P.stop_all_cob_id(), is_extended_id=False,
                            data=P.encode_stop_all()))
    t0 = sched.now_us
    res.stop_trials += 1
    while True:
        sched.run_until(sched.now_us + 5_000)
        tel.advance_plants()
        rates = [abs(p.axis_rate_rad_s) * ARCSEC_PER_RAD for p in tel.plants.values()]
        if max(rates) < STANDSTILL_ARCSEC_S:
            break
        if sched.now_us - t0 > STOP_TIMEOUT_US:
            res.stop_timeouts += 1
            break
    dt_ms = (sched.now_us - t0) / 1000.0
    res.stop_to_standstill_max_ms = max(res.stop_to_standstill_max_ms, dt_ms)
