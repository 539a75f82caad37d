"""An in-process ``hid.device`` look-alike backed by simulated USB HID gateways (docs/usb-gateway.md).

Same calls as the ``hid.device`` class of the PyPI ``hidapi`` package (cython-hidapi), so a
host program written for hidapi runs against the emulated gateway unchanged except for where the
class comes from::

    from host.hid_device import device          # instead of: from hid import device
    h = device(); h.open(0x04D8, 0x003F)
    h.write([0] + list(out_report))             # report number 0, then 64 bytes
    r = h.read(64, 100)                         # list of ints; [] on timeout
    st = h.get_feature_report(0, 65)            # [0] + 64 status bytes

**Simulated time.** A ``read`` with a timeout does not sleep: it *advances the simulated clock*
(``scheduler.run_until``, in 1 ms frames) until a report arrives or the timeout has passed in
simulated time, so the boards and the bus run while the host "waits". ``read(.., 0)`` and a
non-blocking device return at once; ``timeout_ms = -1`` (block) advances at most
:data:`BLOCK_LIMIT_MS` and then raises :class:`bus.errors.HostTimeout` instead of spinning for
ever. ``write`` never advances the clock: the report is queued and the USB host delivers it at
the next 1 ms frame the gateway's OUT endpoint is armed (−1 when the queue is full, as hidapi
returns −1 on a failed write). Feature reports complete at once. Do not call ``read`` with a
timeout from inside a scheduler callback (the scheduler refuses re-entry); pass
``advance=None`` there (then every read is non-blocking).

Devices are found in a :class:`SimUsb` (a simulated PC's USB host), by default the module's
:data:`DEFAULT_USB`: :func:`plug` a gateway into it.
"""

from __future__ import annotations

from typing import Any, Callable, Dict, Final, List, Optional

from mypy_extensions import mypyc_attr

from boards.usb_hid import MANUFACTURER, PRODUCT, PRODUCT_ID, REPORT_DESCRIPTOR, VENDOR_ID
from bus.errors import HostTimeout
from bus.hid_reports import REPORT_SIZE
from bus.usb_link import FRAME_PERIOD_US, UsbHostPort

__all__ = ["device", "enumerate", "plug", "unplug", "SimUsb", "DEFAULT_USB", "BLOCK_LIMIT_MS"]

#: Longest simulated wait of a blocking read (timeout −1), ms (assumed: 10 s, far above any
#: report interval of the network; a host waiting longer has lost the gateway).
BLOCK_LIMIT_MS: Final = 10_000


class _Plugged:
    def __init__(self, gateway, port: UsbHostPort, advance, serial: str, path: bytes) -> None:
        self.gateway, self.port, self.advance, self.serial, self.path = gateway, port, advance, serial, path
        self.open_count = 0


class SimUsb:
    """A simulated PC's USB host: the gateways plugged into it, by path."""

    def __init__(self) -> None:
        self.devices: Dict[bytes, _Plugged] = {}
        self._n = 0

    def plug(self, gateway, *, advance: Any = "run_until",
             serial: Optional[str] = None, **port_kw) -> UsbHostPort:
        """Connect ``gateway`` (a :class:`boards.usb_gateway.UsbGateway`) with a new host port.

        Parameters
        ----------
        advance : callable(t_us) or None
            How a blocking ``read`` advances time; default the gateway scheduler's
            ``run_until``; None makes every read non-blocking.
        serial : str, optional
            Serial number string (default ``"SIM<n>"``).
        **port_kw
            Passed to :class:`bus.usb_link.UsbHostPort`.
        """
        self._n += 1
        sched = gateway.scheduler
        adv = sched.run_until if advance == "run_until" else advance
        port = UsbHostPort(sched, gateway.usb, name=f"usb-host/{gateway.name}", **port_kw)
        path = f"sim-usb:{self._n}".encode()
        self.devices[path] = _Plugged(gateway, port, adv, serial or f"SIM{self._n}", path)
        return port

    def unplug(self, gateway) -> None:
        """Disconnect ``gateway``; open handles fail from then on."""
        for path, d in list(self.devices.items()):
            if d.gateway is gateway:
                d.port.shutdown()
                del self.devices[path]


#: The USB host that :class:`device` searches by default.
DEFAULT_USB: Final = SimUsb()


def plug(gateway, **kw) -> UsbHostPort:
    """:meth:`SimUsb.plug` on :data:`DEFAULT_USB`."""
    return DEFAULT_USB.plug(gateway, **kw)


def unplug(gateway) -> None:
    """:meth:`SimUsb.unplug` on :data:`DEFAULT_USB`."""
    DEFAULT_USB.unplug(gateway)


def enumerate(vendor_id: int = 0, product_id: int = 0, *, usb: Optional[SimUsb] = None) -> List[dict]:  # noqa: A001
    """hidapi's ``enumerate``: one dict per matching device (0 = any id)."""
    usb = usb or DEFAULT_USB
    out = []
    for d in usb.devices.values():
        if d.gateway.usb.configured and vendor_id in (0, VENDOR_ID) and product_id in (0, PRODUCT_ID):
            out.append({"path": d.path, "vendor_id": VENDOR_ID, "product_id": PRODUCT_ID,
                        "serial_number": d.serial, "release_number": 0x0100,
                        "manufacturer_string": MANUFACTURER, "product_string": PRODUCT,
                        "usage_page": 0xFF00, "usage": 0x01, "interface_number": 0})
    return out


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py)
class device:  # noqa: N801 - the name hidapi uses
    """hidapi's ``hid.device`` on a simulated gateway (see the module docstring for time)."""

    def __init__(self, *, usb: Optional[SimUsb] = None) -> None:
        self._usb = usb or DEFAULT_USB
        self._d: Optional[_Plugged] = None
        self._nonblocking = False
        self._error = ""

    # -- opening -----------------------------------------------------------------------------
    def open(self, vendor_id: int = 0, product_id: int = 0, serial_number: Optional[str] = None) -> None:
        """Open the first gateway with these ids (and serial); raises OSError("open failed")."""
        for info in enumerate(vendor_id, product_id, usb=self._usb):
            if serial_number is None or info["serial_number"] == serial_number:
                return self.open_path(info["path"])
        raise OSError("open failed")

    def open_path(self, path: bytes) -> None:
        """Open by ``path`` from :func:`enumerate`; raises OSError("open failed")."""
        d = self._usb.devices.get(bytes(path))
        if d is None or not d.gateway.usb.configured:
            raise OSError("open failed")
        self._d = d
        d.open_count += 1
        d.port.open()

    def set_report_callback(self, callback: Optional[Callable[[], None]]) -> None:
        """Call ``callback()`` each time the USB host buffers an IN report for this device (not
        in hidapi: the in-process stand-in for a PC thread blocked in ``read``, so a reader
        inside the simulation takes each report in the 1 ms frame it arrives, without a poll
        event of its own). ``None`` removes it; :meth:`close` does too."""
        self._dev().port.on_buffered = callback

    def close(self) -> None:
        """Close; the host stops polling when the last handle is closed."""
        if self._d is not None:
            if self._d.port.on_buffered is not None:
                self._d.port.on_buffered = None
            self._d.open_count -= 1
            if self._d.open_count <= 0:
                self._d.port.close()
            self._d = None

    def _dev(self) -> _Plugged:
        if self._d is None or self._usb.devices.get(self._d.path) is not self._d:
            raise ValueError("not open")
        return self._d

    def set_nonblocking(self, v) -> int:
        """Non-blocking reads (``read`` never advances time)."""
        self._nonblocking = bool(v)
        return 0

    # -- reports -----------------------------------------------------------------------------
    def write(self, buff) -> int:
        """Queue an OUT report: ``buff[0]`` is the report number (0), then the report bytes.

        Returns the number of bytes taken (``len(buff)``), or −1 (report number not 0, or the
        OUT queue is full; :meth:`error` says which). The report is delivered as given: a report
        that is not 64 bytes reaches the gateway, which counts it as malformed.
        """
        d = self._dev()
        b = bytes(buff)
        if not b or b[0] != 0:
            self._error = "report number must be 0 (the gateway has no report IDs)"
            return -1
        if not d.port.write(b[1:]):
            self._error = "OUT queue full: the gateway is not taking reports"
            return -1
        return len(b)

    def _wait(self, d: _Plugged, timeout_ms: int) -> None:
        """Advance simulated time (1 ms frames) until a report is buffered or the timeout ends."""
        port = d.port
        if port.received or self._nonblocking or not timeout_ms or d.advance is None:
            return
        sched = d.gateway.scheduler
        limit = BLOCK_LIMIT_MS if timeout_ms < 0 else int(timeout_ms)
        deadline = sched.now_us + limit * 1000
        while not port.received and sched.now_us < deadline:
            d.advance(min((sched.now_us // FRAME_PERIOD_US + 1) * FRAME_PERIOD_US, deadline))
        if not port.received and timeout_ms < 0:
            raise HostTimeout(f"hid read: no IN report within {BLOCK_LIMIT_MS} ms of simulated time")

    def read(self, max_length: int, timeout_ms: int = 0) -> List[int]:
        """Next IN report (at most ``max_length`` bytes) as a list of ints; ``[]`` on timeout.

        ``timeout_ms`` > 0 advances the simulated clock up to that long; −1 blocks (advances
        up to :data:`BLOCK_LIMIT_MS`, then raises ``HostTimeout``).
        """
        return self.read_timed(max_length, timeout_ms)[1]

    def read_timed(self, max_length: int, timeout_ms: int = 0):
        """:meth:`read`, also returning the simulated time the USB host took the report, µs
        (``(None, [])`` on timeout). Not in hidapi: for latency measurements."""
        d = self._dev()
        self._wait(d, timeout_ms)
        if not d.port.received:
            return None, []
        t, report = d.port.received.popleft()
        return t, list(report[:max_length])

    def sim_read_report(self, timeout_ms: int = 0) -> Optional[bytes]:
        """:meth:`read` of a whole report as ``bytes`` (None on timeout) instead of a list of
        ints. Not in hidapi: :class:`host.gateway_bus.HidGatewayBus` uses it on this in-process
        device to skip the list round trip."""
        d = self._dev()
        self._wait(d, timeout_ms)
        received = d.port.received
        if not received:
            return None
        return bytes(received.popleft()[1])

    def get_feature_report(self, report_id: int, max_length: int) -> List[int]:
        """GET_REPORT(Feature): ``[report_id] + 64 status bytes`` (truncated to ``max_length``).

        Raises OSError if the report id is not 0 or the gateway stalls the request.
        """
        d = self._dev()
        if report_id != 0:
            raise OSError("get_feature_report: the gateway has only report 0")
        r = d.port.get_feature()
        if r is None:
            raise OSError("get_feature_report: request stalled")
        return ([0] + list(r))[:max_length]

    def send_feature_report(self, data) -> int:
        """SET_REPORT(Feature): ``data[0]`` = 0 then the 64-byte command; bytes sent or −1."""
        d = self._dev()
        b = bytes(data)
        if not b or b[0] != 0:
            self._error = "report number must be 0"
            return -1
        if not d.port.set_feature(b[1:]):
            self._error = "the gateway refused the command (stalled): see its status report"
            return -1
        return len(b)

    def get_report_descriptor(self, max_length: int = 4096) -> List[int]:
        """The HID report descriptor (hidapi ≥ 0.14)."""
        return list(REPORT_DESCRIPTOR[:max_length])

    # -- strings -------------------------------------------------------------------------------
    def get_manufacturer_string(self) -> str:
        self._dev()
        return MANUFACTURER

    def get_product_string(self) -> str:
        self._dev()
        return PRODUCT

    def get_serial_number_string(self) -> str:
        return self._dev().serial

    def error(self) -> str:
        """Text of the last failure of :meth:`write` / :meth:`send_feature_report`."""
        return self._error

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def report_size(self) -> int:
        """Bytes of every report after the report number (64)."""
        return REPORT_SIZE
