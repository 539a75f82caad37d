"""The emulated USB-HID CAN gateway as a real Linux HID device, through ``/dev/uhid``.

``python -m host.uhid_gateway`` builds the five boards and the plant on the in-process bus
(:func:`host.network.build_network`, the host node a passive :class:`host.monitor.BusMonitor`),
powers the network's gateway board (:class:`boards.usb_gateway.UsbGateway`, registry name ``gateway``; a
passive host leaves it unpowered) as the PC's node,
and creates a HID device with ``/dev/uhid`` (``UHID_CREATE2``: USB bus, the gateway's vendor and
product id, its report descriptor). The kernel's hid-generic driver binds it and makes a
``/dev/hidrawN``; an unmodified program using hidapi (hidraw backend) or raw hidraw opens it as
it would open the real board (docs/usb-gateway.md). Simulated time is paced to the wall clock
in 1 ms USB frames; when the process falls behind it runs the frames back to back (never skips;
uhid events are answered every 10 ms of simulated time meanwhile) and reports how far behind it
was.

Translation between uhid events and the simulated USB host (:class:`bus.usb_link.UsbHostPort`):

* ``UHID_OPEN`` / ``UHID_CLOSE`` (a program opened / the last one closed ``/dev/hidrawN``):
  the host starts / stops polling the IN endpoint (as usbhid submits its IN URB only while open);
* each IN report the host takes → ``UHID_INPUT2`` (64 bytes, no report number);
* ``UHID_OUTPUT`` (a ``write`` on hidraw: report number 0, then the report) → the OUT queue;
* ``UHID_GET_REPORT`` (feature, report 0) → ``UHID_GET_REPORT_REPLY`` with ``[0] + status``;
  ``UHID_SET_REPORT`` (feature, report 0) → the command, replied with error 0 or ``EIO`` when
  the gateway stalls it; other report types or numbers → ``EIO``.

Linux only (``/dev/uhid``, module ``uhid``; creating a device needs write access to it, normally
root). Struct layouts: ``include/uapi/linux/uhid.h``.
"""

from __future__ import annotations

import argparse
import errno
import json
import os
import select
import signal
import struct
import sys
import time
from pathlib import Path

from boards.usb_gateway import UsbGateway
from boards.usb_hid import PRODUCT, PRODUCT_ID, REPORT_DESCRIPTOR, VENDOR_ID
from bus.errors import SchmidtFilError
from bus.usb_link import FRAME_PERIOD_US, UsbHostPort

__all__ = ["Uhid", "UhidGateway", "UhidUnavailable", "main"]

# include/uapi/linux/uhid.h
UHID_DESTROY, UHID_START, UHID_STOP, UHID_OPEN, UHID_CLOSE, UHID_OUTPUT = 1, 2, 3, 4, 5, 6
UHID_GET_REPORT, UHID_GET_REPORT_REPLY, UHID_CREATE2, UHID_INPUT2 = 9, 10, 11, 12
UHID_SET_REPORT, UHID_SET_REPORT_REPLY = 13, 14
UHID_FEATURE_REPORT, UHID_OUTPUT_REPORT, UHID_INPUT_REPORT = 0, 1, 2
UHID_DATA_MAX = 4096
BUS_USB = 0x03
_CREATE2 = struct.Struct("<I128s64s64sHHIIII4096s")
#: sizeof(struct uhid_event): the type plus the largest member (uhid_create2_req)
EVENT_SIZE = _CREATE2.size
#: Longest stretch of simulated time run without answering uhid events while catching up, µs
#: (assumed: 10 ms, ten USB frames: fewer event checks while behind; on time the bridge steps
#: single 1 ms frames).
CATCHUP_CHUNK_US = 10_000
EVENT_NAMES = {UHID_START: "START", UHID_STOP: "STOP", UHID_OPEN: "OPEN", UHID_CLOSE: "CLOSE",
               UHID_OUTPUT: "OUTPUT", UHID_GET_REPORT: "GET_REPORT", UHID_SET_REPORT: "SET_REPORT"}


class UhidUnavailable(SchmidtFilError):
    """``/dev/uhid`` cannot be opened (not Linux, module not loaded, or no permission)."""


class Uhid:
    """A ``/dev/uhid`` file descriptor with the events the gateway uses."""

    def __init__(self, path: str = "/dev/uhid") -> None:
        try:
            self.fd = os.open(path, os.O_RDWR | os.O_CLOEXEC | os.O_NONBLOCK)
        except OSError as exc:
            raise UhidUnavailable(
                f"cannot open {path}: {exc.strerror} (Linux with the uhid module loaded "
                f"(modprobe uhid) and write access to {path}, normally root)") from None
        self.path = path

    @classmethod
    def from_fd(cls, fd: int, path: str = "<fd>") -> "Uhid":
        """Wrap an already open descriptor (tests use one end of a SOCK_SEQPACKET pair)."""
        u = cls.__new__(cls)
        u.fd, u.path = fd, path
        return u

    def create(self, name: str, vendor_id: int, product_id: int, descriptor: bytes, *,
               phys: str = "schmidt-fil/usb-gateway", uniq: str = "SIM0001", version: int = 0x0100) -> None:
        """``UHID_CREATE2``: the kernel adds a USB HID device with this report descriptor."""
        os.write(self.fd, _CREATE2.pack(UHID_CREATE2, name.encode()[:127], phys.encode()[:63],
                                        uniq.encode()[:63], len(descriptor), BUS_USB, vendor_id,
                                        product_id, version, 0, descriptor))

    def input(self, report: bytes) -> None:
        """``UHID_INPUT2``: one input report (no report number: the device has no report IDs)."""
        os.write(self.fd, struct.pack("<IH", UHID_INPUT2, len(report)) + bytes(report))

    def get_report_reply(self, req_id: int, err: int, data: bytes = b"") -> None:
        os.write(self.fd, struct.pack("<IIHH", UHID_GET_REPORT_REPLY, req_id, err, len(data)) + bytes(data))

    def set_report_reply(self, req_id: int, err: int) -> None:
        os.write(self.fd, struct.pack("<IIH", UHID_SET_REPORT_REPLY, req_id, err))

    def read_event(self):
        """Next event as ``(type, fields)`` or None when none is pending."""
        try:
            b = os.read(self.fd, EVENT_SIZE)
        except BlockingIOError:
            return None
        (etype,) = struct.unpack_from("<I", b, 0)
        if etype == UHID_OUTPUT:
            size, rtype = struct.unpack_from("<HB", b, 4 + UHID_DATA_MAX)
            return etype, {"data": b[4:4 + size], "rtype": rtype}
        if etype == UHID_GET_REPORT:
            req_id, rnum, rtype = struct.unpack_from("<IBB", b, 4)
            return etype, {"id": req_id, "rnum": rnum, "rtype": rtype}
        if etype == UHID_SET_REPORT:
            req_id, rnum, rtype, size = struct.unpack_from("<IBBH", b, 4)
            return etype, {"id": req_id, "rnum": rnum, "rtype": rtype, "data": b[12:12 + size]}
        return etype, {}

    def close(self) -> None:
        """``UHID_DESTROY`` and close (the hidraw node goes away)."""
        if self.fd is not None:
            try:
                os.write(self.fd, struct.pack("<I", UHID_DESTROY))
            except OSError:
                pass
            os.close(self.fd)
            self.fd = None


class UhidGateway:
    """The gateway firmware on the emulated network, exposed as a uhid device.

    Parameters
    ----------
    telescope : host.network.Telescope
        The built network (``sim`` bus); the gateway is added to its CAN network.
    uhid : Uhid
        An open ``/dev/uhid``.
    """

    def __init__(self, telescope, uhid: Uhid) -> None:
        from boards.registry import GATEWAY_KIND, nodes_of_kind

        if telescope.network is None:
            raise SchmidtFilError("the uhid gateway needs the in-process bus (scenario bus.interface: sim)")
        self.tel = telescope
        self.sched = telescope.scheduler
        # the network's own gateway board (registry kind usb_gateway), left unpowered by a
        # passive host; plugging it into this USB host powers it
        name, = nodes_of_kind(GATEWAY_KIND)
        self.gateway: UsbGateway = telescope.boards[name]
        self.bus = self.gateway.can.bus
        self.port = UsbHostPort(self.sched, self.gateway.usb, name="usb-host/uhid")
        self.port.on_in_report = lambda report, now_us: self.uhid.input(report)
        self.uhid = uhid
        self.events: dict = {}
        self.output_sizes: dict = {}
        self.started = False
        self.frames_late = 0
        self.max_late_us = 0
        self.gateway.start()
        uhid.create(PRODUCT, VENDOR_ID, PRODUCT_ID, REPORT_DESCRIPTOR)

    def handle_events(self) -> None:
        """Answer every pending uhid event."""
        while True:
            ev = self.uhid.read_event()
            if ev is None:
                return
            etype, f = ev
            name = EVENT_NAMES.get(etype, str(etype))
            self.events[name] = self.events.get(name, 0) + 1
            if etype == UHID_START:
                self.started = True
            elif etype == UHID_OPEN:
                self.port.open()
            elif etype == UHID_CLOSE:
                self.port.close()
            elif etype == UHID_OUTPUT:
                # hidraw passes the buffer it was given: report number (0) first, then the report
                data = f["data"]
                self.output_sizes[len(data)] = self.output_sizes.get(len(data), 0) + 1
                self.port.write(data[1:] if data[:1] == b"\0" else data)
            elif etype == UHID_GET_REPORT:
                r = self.port.get_feature() if (f["rtype"] == UHID_FEATURE_REPORT and f["rnum"] == 0) else None
                if r is None:
                    self.uhid.get_report_reply(f["id"], errno.EIO)
                else:
                    self.uhid.get_report_reply(f["id"], 0, b"\0" + r)
            elif etype == UHID_SET_REPORT:
                ok = f["rtype"] == UHID_FEATURE_REPORT and f["rnum"] == 0 and self.port.set_feature(f["data"][1:])
                self.uhid.set_report_reply(f["id"], 0 if ok else errno.EIO)

    def run(self, duration_s: float | None = None, should_stop=lambda: False, on_ready=None) -> None:
        """Pace simulated time to the wall clock in 1 ms frames, answering uhid events between."""
        sched = self.sched
        t0_wall = time.monotonic()
        t0_sim = sched.now_us
        end_us = None if duration_s is None else t0_sim + int(duration_s * 1e6)
        ready_sent = False
        while not should_stop() and (end_us is None or sched.now_us < end_us):
            if self.started and not ready_sent and on_ready is not None:
                on_ready()
                ready_sent = True
            target = t0_sim + int((time.monotonic() - t0_wall) * 1e6) // FRAME_PERIOD_US * FRAME_PERIOD_US
            if target > sched.now_us:
                late = target - sched.now_us - FRAME_PERIOD_US
                if late > 0:
                    self.frames_late += 1
                    self.max_late_us = max(self.max_late_us, late)
                # catch up in chunks of at most CATCHUP_CHUNK_US, answering uhid events between
                sched.run_until(min(target, sched.now_us + CATCHUP_CHUNK_US))
                self.handle_events()
                continue
            wait = (t0_wall + (sched.now_us - t0_sim + FRAME_PERIOD_US) / 1e6) - time.monotonic()
            select.select([self.uhid.fd], [], [], max(0.0, wait))
            self.handle_events()

    def summary(self) -> dict:
        """Gateway counters, uhid events and pacing, for the exit line / ``--summary``."""
        g = self.gateway
        return {"simulated_s": self.sched.now_us / 1e6, "gateway": g.status()._asdict(),
                "rx_unsupported": g.rx_unsupported, "uhid_events": self.events,
                "uhid_output_sizes": self.output_sizes,
                "usb": {"in_reports": self.port.in_reports, "out_reports": self.port.out_reports,
                        "out_rejected": self.port.out_rejected, "frames": self.port.frames},
                "pacing": {"frames_late": self.frames_late, "max_late_us": self.max_late_us}}

    def close(self) -> None:
        self.uhid.close()
        self.port.shutdown()
        self.tel.close()


def main(argv=None) -> int:
    """``python -m host.uhid_gateway``: see the module docstring and docs/usb-gateway.md."""
    ap = argparse.ArgumentParser(prog="python -m host.uhid_gateway",
                                 description="Serve the emulated USB-HID CAN gateway as a real HID "
                                             "device through /dev/uhid (docs/usb-gateway.md).")
    ap.add_argument("--scenario", help="scenario for the boards and plant (bus must be sim; "
                                       "default: scenarios/tracking-low-preload.yaml)")
    ap.add_argument("--duration", type=float, help="stop after this many simulated seconds")
    ap.add_argument("--uhid", default="/dev/uhid", help="uhid device node (default /dev/uhid)")
    ap.add_argument("--ready-file", help="write this file once the HID device exists")
    ap.add_argument("--summary", help="write the exit summary (JSON) here as well")
    a = ap.parse_args(argv)
    from host.monitor import BusMonitor
    from host.network import build_network
    from host.scenario import ScenarioError, load_scenario
    from host.serve import DEFAULT_SCENARIO

    prog = "schmidt-fil uhid gateway"
    try:
        sc = load_scenario(a.scenario or DEFAULT_SCENARIO)
        if sc.bus.interface != "sim":
            raise ScenarioError(sc.source_path, None, "bus.interface", "the uhid gateway runs the boards on 'sim'")
        uhid = Uhid(a.uhid)
    except SchmidtFilError as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return 2
    stop = {"flag": False}
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.update(flag=True))
    tel = build_network(sc, host_cls=BusMonitor)
    gw = UhidGateway(tel, uhid)
    print(f"{prog}: boards built, UHID_CREATE2 sent; waiting for the kernel to start the device",
          file=sys.stderr, flush=True)

    def ready():
        print(f"{prog}: {VENDOR_ID:04x}:{PRODUCT_ID:04x} '{PRODUCT}' up; boards "
              f"{', '.join(tel.boards)} on the in-process bus; Ctrl-C stops", flush=True)
        if a.ready_file:
            Path(a.ready_file).write_text(json.dumps({"vendor_id": VENDOR_ID, "product_id": PRODUCT_ID,
                                                      "pid": os.getpid()}))
    try:
        gw.run(a.duration, should_stop=lambda: stop["flag"], on_ready=ready)
    finally:
        s = gw.summary()
        gw.close()
        print(f"{prog}: stopped; {json.dumps(s)}", flush=True)
        if a.summary:
            Path(a.summary).write_text(json.dumps(s, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
