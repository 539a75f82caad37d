"""Dome controller firmware, node 0x0D (issue 12; paper §5.2: dome control "implemented and
tested in the lab on RS232 ports"; the paper gives no dome hardware, so every number is assumed:
plant/parameters.yaml ``dome`` and ``site``).

Peripherals: an SSI absolute azimuth encoder (:class:`boards.peripherals.AbsoluteEncoderInput`),
a DAC giving the dome drive's speed reference (:class:`boards.peripherals.Dac`), CAN.

Control loop (timer ISR every ``control_period_us``, 50 ms): read the azimuth, find the target
of the present mode, and ramp the commanded rate toward

    v_des = sign(e) · min(v_max, sqrt(2 · 0.8·a · |e|))       (a trapezoidal move that stops at
                                                              the target with deceleration 0.8·a)

by at most ``a · period`` per period, e = target − azimuth wrapped to (−180°, 180°]. The dome
starts a move only when |e| > deadband, and ends it (v_des = 0) once |e| ≤ 0.1°; then it waits
until the slit is off by more than the deadband again. So |rate| ≤ ``max_rate_deg_s`` and
|Δrate| ≤ ``acceleration_deg_s2`` · period (+ one DAC step) always hold: tested on the plant's
truth (tests/test_room_nodes.py).

Modes (``DOME_COMMAND``, RPDO1 0x20D):

* FOLLOW — the slit follows the telescope: target = :func:`slit_azimuth_deg` of the hour angle and
  declination read from the readers' POSITION frames (RPDO2/RPDO4, 0x183/0x184) and the site
  latitude. Without a POSITION of either axis newer than ``position_timeout_us`` it holds (rate
  ramps to 0) and sets POSITION_STALE.
* GOTO — target = the command's azimuth (centi-degrees 0 .. 35999); outside that range the
  command is refused (EMCY COMMAND_REFUSED, reason 7 ``REFUSE_AZIMUTH``, state unchanged).
* PARK — target = the park azimuth (0x2400:4); PARKED once there.
* STOP, STOP_ALL (RPDO3), NMT leaving OPERATIONAL — mode IDLE, rate ramps to 0 at the
  acceleration limit (a controlled stop).

``DOME_STATUS`` (TPDO1, 0x18D) every 250 ms: mode, flags (moving, on_target, parked,
position_stale), azimuth and target in centi-degrees.

Telescope position convention (as :mod:`boards.position_reader`): the RA reader's position read
as a signed 29-bit angle is the hour angle (positive west), the DEC reader's the declination.

Not emulated: the off-axis offset of the tube on its equatorial mount (the slit azimuth is that of
the optical axis from the dome centre), the shutter, the drive's current and thermal limits.
"""

from __future__ import annotations

import math
from typing import Callable, Final, Optional

import can

from boards.firmware_base import Board
from boards.peripherals import AbsoluteEncoderInput, Dac, Timer
from boards.safety import REFUSE_AZIMUTH
from boards.services import ObjectRefused
from bus import protocol as proto
from bus.scheduler import PRIO_ISR, Scheduler
from mypy_extensions import mypyc_attr

__all__ = ["DomeController", "slit_azimuth_deg", "ARRIVE_TOL_DEG", "PROFILE_DECEL_FRACTION"]

#: A move ends when the slit is within this of its target, deg (assumed: 1/20 of the deadband).
ARRIVE_TOL_DEG: Final = 0.1
#: The braking profile uses this fraction of the acceleration limit, so the rate ramp (at the
#: full limit) can follow the profile one period late without overshooting (assumed).
PROFILE_DECEL_FRACTION: Final = 0.8
_POS_HALF: Final = 1 << 28
_DEG_PER_POS_COUNT: Final = 360.0 / (1 << 29)
_POSITION_INVALID: Final = int(proto.PositionFlags.INVALID)    # a plain int: tested for every frame


def slit_azimuth_deg(ha_deg: float, dec_deg: float, latitude_deg: float) -> float:
    """Azimuth of a direction given by hour angle and declination, deg (N = 0, E = 90, 0..360).

    A = atan2(−cos δ sin H, sin δ cos φ − cos δ cos H sin φ) (spherical astronomy, e.g. Meeus,
    *Astronomical Algorithms*, ch. 13, with the azimuth counted from north instead of south).

    Parameters
    ----------
    ha_deg : float
        Hour angle, deg (positive west).
    dec_deg : float
        Declination, deg.
    latitude_deg : float
        Site latitude, deg (north +).
    """
    h, d, p = math.radians(ha_deg), math.radians(dec_deg), math.radians(latitude_deg)
    a = math.degrees(math.atan2(-math.cos(d) * math.sin(h),
                                math.sin(d) * math.cos(p) - math.cos(d) * math.cos(h) * math.sin(p)))
    return a % 360.0


def _wrap180(x: float) -> float:
    """``x`` wrapped to (−180, 180]."""
    y = math.fmod(x, 360.0)
    if y > 180.0:
        y -= 360.0
    elif y <= -180.0:
        y += 360.0
    return y


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class DomeController(Board):
    """Dome azimuth controller firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board`.
    node_id : int
        0x0D.
    read_azimuth_counts : callable() -> int
        Port: the absolute azimuth encoder word.
    set_speed_reference : callable(fraction)
        Port: the drive's speed reference, −1 .. 1 of full scale (through the DAC).
    latitude_deg : float
        Site latitude, deg (plant/parameters.yaml ``site.latitude_deg``, paper §2).
    max_rate_deg_s, acceleration_deg_s2, deadband_deg, park_azimuth_deg : float
        Drive limits and park position (``dome.*``, assumed).
    vfd_full_scale_deg_s : float
        Dome rate at full-scale speed reference, deg/s.
    encoder_counts_per_rev, dac_bits : int
        Azimuth encoder resolution and DAC resolution.
    control_period_us, position_timeout_us : int
        Control loop period and the POSITION staleness limit, µs.
    status_period_us : int
        DOME_STATUS period, µs (a multiple of the control period).

    Raises
    ------
    ValueError
        A limit that is not positive, or a status period that is not a multiple of the control
        period.
    """

    DEVICE_TYPE = int(proto.DeviceType.DOME)
    KIND = "dome"
    CANOPEN_KIND = "dome"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = int(proto.NodeId.DOME), *,
                 read_azimuth_counts: Callable[[], int], set_speed_reference: Callable[[float], None],
                 latitude_deg: float, max_rate_deg_s: float, acceleration_deg_s2: float,
                 deadband_deg: float, park_azimuth_deg: float, vfd_full_scale_deg_s: float,
                 encoder_counts_per_rev: int, dac_bits: int, control_period_us: int,
                 position_timeout_us: int, status_period_us: int = proto.DOME_STATUS_PERIOD_US,
                 name: Optional[str] = None, serial_port=None) -> None:
        for k, v in (("max_rate_deg_s", max_rate_deg_s), ("acceleration_deg_s2", acceleration_deg_s2),
                     ("deadband_deg", deadband_deg), ("vfd_full_scale_deg_s", vfd_full_scale_deg_s)):
            if not v > 0:
                raise ValueError(f"{k} must be > 0, got {v}")
        if status_period_us % control_period_us:
            raise ValueError("status_period_us must be a multiple of control_period_us")
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=control_period_us,
                         serial_port=None)
        self.latitude_deg = float(latitude_deg)
        self.max_rate_deg_s = float(max_rate_deg_s)
        self.acceleration_deg_s2 = float(acceleration_deg_s2)
        self.deadband_deg = float(deadband_deg)
        self.park_azimuth_deg = float(park_azimuth_deg) % 360.0
        self.vfd_full_scale_deg_s = float(vfd_full_scale_deg_s)
        self.control_period_us = int(control_period_us)
        self.position_timeout_us = int(position_timeout_us)
        self.status_every = int(status_period_us) // int(control_period_us)
        self.encoder = AbsoluteEncoderInput(read_azimuth_counts, encoder_counts_per_rev)
        self.dac = Dac(set_speed_reference, dac_bits)
        self.timer = self.add_timer(Timer(scheduler, self.control_period_us, self.isr_control,
                                          priority=PRIO_ISR, owner=f"{self.name}/isr"))
        self._pos_ids = {proto.position_cob_id(n): i for i, n in enumerate(proto.READER_NODES)}
        self._cmd_id = proto.dome_command_cob_id(self.node_id)
        self.accept_id(self._cmd_id)
        for cob in self._pos_ids:
            self.accept_id(cob)
        self._init_dome_state()

    def _peripherals(self) -> list:
        return [self.encoder, self.dac]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "encoder"):
            self._init_dome_state()

    def _init_dome_state(self) -> None:
        self.mode = proto.DomeMode.IDLE
        self.goto_deg = 0.0
        self.rate_deg_s = 0.0              # the commanded (ramped) rate
        self.moving = False
        self.on_target = False
        self.parked = False
        self.position_stale = False
        self.azimuth_deg = 0.0
        self.target_deg = 0.0
        self._pos: list = [None, None]     # (pos_counts, t_us) of RA, DEC
        self._passes = 0
        self.position_frames = 0
        self.moves = 0

    def report_counters(self) -> dict:
        """Moves started and POSITION frames consumed (report board row)."""
        return {"moves": self.moves, "position_frames": self.position_frames,
                "azimuth_deg": round(self.azimuth_deg, 3), "mode": self.mode.name}

    # ------------------------------------------------------------------ telescope position
    def telescope_ha_dec_deg(self, now_us: int) -> Optional[tuple]:
        """(hour angle, declination) in deg from the last POSITION frames, or None if either is
        missing or older than ``position_timeout_us``."""
        out: list = []
        for p in self._pos:
            if p is None or now_us - p[1] > self.position_timeout_us:
                return None
            c = p[0]
            out.append((c - (1 << 29) if c >= _POS_HALF else c) * _DEG_PER_POS_COUNT)
        return out[0], out[1]

    def _target(self, now_us: int) -> Optional[float]:
        self.position_stale = False
        if self.mode == proto.DomeMode.FOLLOW:
            hd = self.telescope_ha_dec_deg(now_us)
            if hd is None:
                self.position_stale = True
                return None
            return slit_azimuth_deg(hd[0], hd[1], self.latitude_deg)
        if self.mode == proto.DomeMode.GOTO:
            return self.goto_deg
        if self.mode == proto.DomeMode.PARK:
            return self.park_azimuth_deg
        return None

    # ------------------------------------------------------------------ ISR
    def isr_control(self, now_us: int) -> None:
        """Control ISR: read the azimuth, ramp the rate toward the move profile, write the DAC."""
        n = self.encoder.counts_per_rev
        self.azimuth_deg = self.encoder.read() * 360.0 / n
        target = self._target(now_us)
        v_des = 0.0
        if target is None:
            self.on_target = False
            self.moving = False if self.rate_deg_s == 0.0 else self.moving
        else:
            self.target_deg = target
            e = _wrap180(target - self.azimuth_deg)
            if not self.moving and abs(e) > self.deadband_deg:
                self.moving = True
                self.moves += 1
            if self.moving and abs(e) > ARRIVE_TOL_DEG:
                v_des = math.copysign(min(self.max_rate_deg_s, math.sqrt(
                    2.0 * PROFILE_DECEL_FRACTION * self.acceleration_deg_s2 * abs(e))), e)
            self.on_target = abs(e) <= self.deadband_deg
        dv = self.acceleration_deg_s2 * self.control_period_us * 1e-6
        v = self.rate_deg_s + max(-dv, min(dv, v_des - self.rate_deg_s))
        if abs(v) < 1e-9:
            v = 0.0
        if self.moving and v == 0.0 and v_des == 0.0:
            self.moving = False              # the move is over (arrived, or holding)
        written = self.dac.write(v / self.vfd_full_scale_deg_s)
        self.rate_deg_s = written * self.vfd_full_scale_deg_s
        self.parked = (self.mode == proto.DomeMode.PARK and self.on_target and not self.moving)
        self._passes += 1
        if self._passes % self.status_every == 0:
            self.queue(proto.dome_status_cob_id(self.node_id), proto.encode_dome_status(
                self.mode, self.status_flags(), int(round(self.azimuth_deg * 100)) % 36_000,
                int(round(self.target_deg * 100)) % 36_000))

    def status_flags(self) -> int:
        """DOME_STATUS flags byte."""
        f = 0
        if self.moving:
            f |= proto.DomeFlags.MOVING
        if self.on_target:
            f |= proto.DomeFlags.ON_TARGET
        if self.parked:
            f |= proto.DomeFlags.PARKED
        if self.position_stale:
            f |= proto.DomeFlags.POSITION_STALE
        return int(f)

    # ------------------------------------------------------------------ receive
    def handle_frame(self, arbitration_id: int, data: bytes) -> None:
        axis = self._pos_ids.get(arbitration_id)
        if axis is not None:
            p = proto.decode_position(data)
            if not p.flags & _POSITION_INVALID:
                self._pos[axis] = (p.pos_counts, self.scheduler.now_us)
            self.position_frames += 1
            return
        if arbitration_id != self._cmd_id:
            super().handle_frame(arbitration_id, data)
            return
        c = proto.decode_dome_command(data)
        if c.cmd == proto.DomeCommand.GOTO:
            if not 0 <= c.value <= proto.AZIMUTH_CDEG_MAX:
                self.refuse(REFUSE_AZIMUTH, c.cmd)      # state unchanged
                return
            self.goto_deg = c.value / 100.0
            self.mode = proto.DomeMode.GOTO
        elif c.cmd == proto.DomeCommand.FOLLOW:
            self.mode = proto.DomeMode.FOLLOW
        elif c.cmd == proto.DomeCommand.PARK:
            self.mode = proto.DomeMode.PARK
        else:
            self.stop_all()

    def stop_all(self) -> None:
        """STOP / STOP_ALL / leaving OPERATIONAL: mode IDLE, the rate ramps to zero."""
        self.mode = proto.DomeMode.IDLE

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2400 drive limits, park azimuth and site latitude."""
        if index == 0x2400:
            return {1: int(round(self.max_rate_deg_s * 1000)), 2: int(round(self.acceleration_deg_s2 * 1000)),
                    3: int(round(self.deadband_deg * 100)), 4: int(round(self.park_azimuth_deg * 100)),
                    5: int(round(self.latitude_deg * 1e6))}.get(subindex)
        return super().od_read(index, subindex)

    def od_write(self, index: int, subindex: int, value) -> None:
        """Deadband and park azimuth (range-checked against the EDS by the SDO server)."""
        if index == 0x2400 and subindex == 3:
            self.deadband_deg = value / 100.0
        elif index == 0x2400 and subindex == 4:
            if not 0 <= value <= proto.AZIMUTH_CDEG_MAX:
                raise ObjectRefused(reason="park azimuth must be 0..35999 centi-degrees")
            self.park_azimuth_deg = value / 100.0
        else:
            super().od_write(index, subindex, value)
