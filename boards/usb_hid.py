"""USB full-speed HID interface of the PIC18F4550 (device side), modelling only what the gateway
firmware uses.

One interface, no report IDs, a 64-byte Input report on an interrupt IN endpoint, a 64-byte
Output report on an interrupt OUT endpoint (both bInterval = 1 ms) and a 64-byte Feature report
on the control endpoint. The USB host (``bus.usb_link.UsbHostPort``) services the endpoints once
per 1 ms frame; this peripheral holds the endpoint buffers and their ownership, like the
PIC18F4550's buffer descriptors (UOWN bit: the serial interface engine owns an armed buffer):

* **IN**: the firmware arms the endpoint with one report (:meth:`arm_in`); at the next frame the
  host takes it (``on_in_done`` interrupt) or, with nothing armed, the device NAKs.
* **OUT**: the firmware re-arms the endpoint (:meth:`arm_out`) when it can take a report; the
  host delivers at most one report per frame to an armed endpoint (``on_out`` interrupt), else it
  is NAKed and the host retries next frame (back-pressure, nothing lost).
* **Feature**: GET_REPORT / SET_REPORT control transfers call ``on_get_feature()`` /
  ``on_set_feature(report) -> bool`` (False = the request is stalled).
* **SOF**: ``on_sof(now_us)`` at the start of every frame (the 1 ms start-of-frame interrupt).

Nothing here reads the wall clock or schedules events: the host port's frame event drives it.
Sources: USB 2.0 §5.7 (interrupt transfers, 64-byte maximum packet at full speed), HID 1.11
§7.2 (GET_REPORT / SET_REPORT), PIC18F4550 data sheet §17 (USB buffer descriptors, SOF interrupt).
"""

from __future__ import annotations

from typing import Callable, Final, Optional

from bus.usb_link import FRAME_PERIOD_US

__all__ = ["UsbHidInterface", "REPORT_DESCRIPTOR", "VENDOR_ID", "PRODUCT_ID", "FRAME_PERIOD_US",
           "MAX_PACKET_SIZE"]

#: wMaxPacketSize of both interrupt endpoints, bytes (full speed maximum; paper §3.4: 64 bytes).
MAX_PACKET_SIZE: Final = 64
#: USB vendor id: Microchip Technology (assumed: the PIC18F4550 board keeps Microchip's id).
VENDOR_ID: Final = 0x04D8
#: USB product id (assumed: 0x003F, Microchip's custom-HID demo id, which firmware built on
#: Microchip's HID stack keeps unless a product id is bought).
PRODUCT_ID: Final = 0x003F
MANUFACTURER: Final = "schmidt-fil"
PRODUCT: Final = "ARIES Schmidt CAN-USB gateway (emulated PIC18F4550)"

#: HID report descriptor: vendor page 0xFF00, one application collection, 64-byte Input,
#: Output and Feature reports of 8-bit values, no report IDs (HID 1.11 §6.2.2).
REPORT_DESCRIPTOR: Final = bytes([
    0x06, 0x00, 0xFF,  # Usage Page (Vendor Defined 0xFF00)
    0x09, 0x01,        # Usage (0x01)
    0xA1, 0x01,        # Collection (Application)
    0x15, 0x00,        #   Logical Minimum (0)
    0x26, 0xFF, 0x00,  #   Logical Maximum (255)
    0x75, 0x08,        #   Report Size (8)
    0x95, 0x40,        #   Report Count (64)
    0x09, 0x01,        #   Usage (0x01)
    0x81, 0x02,        #   Input (Data, Var, Abs)
    0x09, 0x02,        #   Usage (0x02)
    0x91, 0x02,        #   Output (Data, Var, Abs)
    0x09, 0x03,        #   Usage (0x03)
    0xB1, 0x02,        #   Feature (Data, Var, Abs)
    0xC0,              # End Collection
])


class UsbHidInterface:
    """Device side of one HID interface (endpoint buffers, ownership, interrupts).

    Attributes
    ----------
    on_sof : callable(now_us) or None
        Start-of-frame interrupt.
    on_in_done : callable(now_us) or None
        The host took the armed IN report.
    on_out : callable(report: bytes, now_us) or None
        An OUT report arrived (the endpoint is no longer armed until :meth:`arm_out`).
    on_get_feature : callable() -> bytes, or None
        GET_REPORT(Feature) handler; returns the 64-byte report.
    on_set_feature : callable(report: bytes) -> bool, or None
        SET_REPORT(Feature) handler; False stalls the request.
    """

    def __init__(self) -> None:
        self.on_sof: Optional[Callable[[int], None]] = None
        self.on_in_done: Optional[Callable[[int], None]] = None
        self.on_out: Optional[Callable[[bytes, int], None]] = None
        self.on_get_feature: Optional[Callable[[], bytes]] = None
        self.on_set_feature: Optional[Callable[[bytes], bool]] = None
        #: firmware: true when its SOF interrupt has nothing to do (None: never idle)
        self.firmware_idle: Optional[Callable[[], bool]] = None
        #: set by the host port: ``on_wake(after_now)`` restarts its frame event
        self.on_wake: Optional[Callable[[bool], None]] = None
        self.reset()

    def reset(self) -> None:
        """Bus reset / power-on: not configured, both endpoints disarmed, counters zero."""
        self.configured = False
        self._in: Optional[bytes] = None
        self.out_armed = False
        self.in_naks = 0
        self.out_naks = 0

    # -- firmware side -------------------------------------------------------------------------
    def attach(self) -> None:
        """Firmware enables the USB module (enumeration is not modelled: configured at once)."""
        self.configured = True

    def detach(self) -> None:
        """Firmware disables the USB module (the host sees the device go away)."""
        self.reset()

    @property
    def in_armed(self) -> bool:
        """True while an IN report waits for the host."""
        return self._in is not None

    @property
    def in_report(self) -> Optional[bytes]:
        """The armed IN report (None when the endpoint is free); read-only view."""
        return self._in

    def arm_in(self, report: bytes) -> None:
        """Hand one 64-byte IN report to the endpoint (the endpoint must be free)."""
        if self._in is not None:
            raise RuntimeError("IN endpoint already armed")  # a firmware bug, not line noise
        if len(report) != MAX_PACKET_SIZE:
            raise ValueError(f"IN report must be {MAX_PACKET_SIZE} bytes, got {len(report)}")
        self._in = bytes(report)

    def arm_out(self) -> None:
        """Give the OUT endpoint buffer back to the interface: the next OUT report is accepted."""
        self.out_armed = True

    def wake(self, after_now: bool) -> None:
        """Firmware: something for the host may come at the next frame (a CAN frame queued:
        ``after_now=False``; a host-side request: True). See ``bus.usb_link`` (idle frames)."""
        if self.on_wake is not None:
            self.on_wake(after_now)

    # -- host side (called by bus.usb_link.UsbHostPort) -------------------------------------------
    def host_idle(self) -> bool:
        """True when a frame would change nothing but the NAK counter: not configured, or no IN
        report armed and the firmware's SOF idle."""
        if not self.configured:
            return True
        return self._in is None and self.firmware_idle is not None and self.firmware_idle()

    def host_idle_frames(self, n: int) -> None:
        """``n`` frames the host did not run because the device was idle: their IN tokens NAKed."""
        self.in_naks += n

    def host_sof(self, now_us: int) -> None:
        """Start of a 1 ms frame."""
        if self.configured and self.on_sof is not None:
            self.on_sof(now_us)

    def host_poll_in(self, now_us: int) -> Optional[bytes]:
        """IN token: the armed report (and the ``on_in_done`` interrupt) or None (NAK)."""
        if not self.configured or self._in is None:
            self.in_naks += 1
            return None
        report, self._in = self._in, None
        if self.on_in_done is not None:
            self.on_in_done(now_us)
        return report

    def host_out(self, report: bytes, now_us: int) -> bool:
        """OUT token with ``report`` (any length): True if accepted (ACK), False if NAKed."""
        if not self.configured or not self.out_armed:
            self.out_naks += 1
            return False
        self.out_armed = False
        if self.on_out is not None:
            self.on_out(bytes(report), now_us)
        return True

    def host_get_feature(self) -> Optional[bytes]:
        """GET_REPORT(Feature): the report, or None (stall)."""
        if not self.configured or self.on_get_feature is None:
            return None
        return self.on_get_feature()

    def host_set_feature(self, report: bytes) -> bool:
        """SET_REPORT(Feature): True if the firmware accepted it, False (stall) otherwise."""
        if not self.configured or self.on_set_feature is None:
            return False
        return bool(self.on_set_feature(bytes(report)))
