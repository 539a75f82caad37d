"""A python-can bus through the USB-HID CAN gateway: CAN frames in, HID reports out.

:class:`HidGatewayBus` wraps any object shaped like hidapi's ``hid.device`` (``write``,
``read(max_length, timeout_ms)``, ``error``): the in-process :class:`host.hid_device.device` on
a simulated gateway, or the real ``hid.device`` of the PyPI ``hidapi`` package on a real (or
``/dev/uhid``) gateway. So code written against python-can — :class:`host.client.HostClient`
among it — talks through the gateway as the paper's PC did (docs/usb-gateway.md).

* ``send`` puts the frame in an OUT report of its own (one report per frame: the gateway sends
  it at the next 1 ms USB frame; :meth:`send_many` packs up to 4 frames per report).
* ``recv`` returns frames from IN reports; ``timeout`` is handed to ``read`` (on the in-process
  device a timeout advances simulated time; ``recv(0)`` never does). A message's ``timestamp``
  is the gateway's receive time, s since gateway power-on (wraps after 71.6 min).
* IN reports that do not decode are counted in ``malformed_reports``; gaps in the report
  ``seq`` (reports lost between gateway and PC) in ``lost_reports``; the IN flags seen are
  OR-ed into ``flags_seen`` (RX_OVERFLOW: the gateway dropped frames).
"""

from __future__ import annotations

from collections import deque
from typing import Deque, Iterable, Optional

import can

from bus import hid_reports as R
from bus._native import own_abc_cache

__all__ = ["HidGatewayBus"]


class HidGatewayBus(can.BusABC):
    """python-can ``BusABC`` over a hidapi-shaped device opened on the gateway.

    Parameters
    ----------
    device : hid.device-like
        Already opened on the gateway.
    channel : str
        Name shown in ``channel_info``.
    """

    def __init__(self, device, channel: str = "usb-hid-gateway", **kwargs) -> None:
        self.device = device
        self.channel = channel
        self.channel_info = f"USB-HID CAN gateway ({channel})"
        self._rx: Deque[tuple] = deque()      # decoded frames not yet returned
        #: the in-process device's ``sim_read_report`` (bytes, no list of ints), else None
        self._read_bytes = getattr(device, "sim_read_report", None)
        self._last_seq: Optional[int] = None
        self.malformed_reports = 0
        self.lost_reports = 0
        self.flags_seen = 0
        if hasattr(device, "set_report_callback"):    # the in-process device (host/hid_device.py)
            self.set_rx_callback = self._set_rx_callback
        super().__init__(channel=channel, **kwargs)

    def _set_rx_callback(self, callback) -> None:
        """``callback()`` after each IN report the USB host takes (only on a device with
        ``set_report_callback``, i.e. the in-process one): the reader drains with ``recv(0)``
        in the 1 ms frame the report arrives instead of polling (``host.client.HostClient``
        uses it when the bus has it)."""
        self.device.set_report_callback(callback)

    # -- transmit ------------------------------------------------------------------------------
    @staticmethod
    def _frame(msg: can.Message) -> tuple:
        if msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
            raise can.CanOperationError("the gateway carries CAN 2.0A data frames only (is_extended_id=False)")
        if not 0 <= msg.arbitration_id <= 0x7FF or len(msg.data) > 8:
            raise can.CanOperationError(f"bad frame for the gateway: id 0x{msg.arbitration_id:X}, "
                                        f"{len(msg.data)} data bytes (expected ≤ 0x7FF, ≤ 8)")
        return (msg.arbitration_id, bytes(msg.data))

    def _write(self, frames: list) -> None:
        n = self.device.write(b"\0" + R.encode_report(R.KIND_OUT, frames))
        if n is None or n < 0:
            raise can.CanOperationError(f"HID write failed: {self.device.error()}")

    def send(self, msg: can.Message, timeout: Optional[float] = None) -> None:
        """Send ``msg`` in an OUT report of its own. Raises ``can.CanOperationError``."""
        self._write([self._frame(msg)])

    def send_many(self, msgs: Iterable[can.Message]) -> None:
        """Send frames packed 4 per OUT report (the gateway's limit per 1 ms frame)."""
        frames = [self._frame(m) for m in msgs]
        for i in range(0, len(frames), R.FRAMES_PER_REPORT):
            self._write(frames[i:i + R.FRAMES_PER_REPORT])

    # -- receive -------------------------------------------------------------------------------
    def _take(self, report) -> None:
        try:
            flags, seq, frames = R.decode_in_frames(report)
        except R.ReportError:
            self.malformed_reports += 1
            return
        if self._last_seq is not None:
            self.lost_reports += (seq - self._last_seq - 1) % 256
        self._last_seq = seq
        self.flags_seen |= flags
        self._rx.extend(frames)              # (arbitration_id, data, timestamp_us) tuples

    def _read_reports(self, timeout: Optional[float]) -> None:
        """Take every IN report the device has (waiting up to ``timeout`` for the first)."""
        ms = -1 if timeout is None else (0 if timeout <= 0 else max(1, int(round(timeout * 1000))))
        read = self._read_bytes
        if read is not None:                 # the in-process device: the report as bytes
            r = read(ms)
            while r:
                self._take(r)
                r = read(0)
            return
        r = self.device.read(R.REPORT_SIZE, ms)
        while r:
            self._take(bytes(r))
            r = self.device.read(R.REPORT_SIZE, 0)

    def _message(self, f) -> can.Message:
        return can.Message(timestamp=f[2] / 1e6, arbitration_id=f[0], is_extended_id=False,
                           data=f[1], is_rx=True, channel=self.channel)

    def _recv_internal(self, timeout: Optional[float]):
        if not self._rx:
            self._read_reports(timeout)
        if self._rx:
            return self._message(self._rx.popleft()), False
        return None, False

    def recv(self, timeout: Optional[float] = None) -> Optional[can.Message]:
        """Next frame passing the bus filters, or None. The wait happens once, inside the
        device's ``read`` (``timeout=None`` blocks: ``read(.., -1)``; on the in-process device
        that advances simulated time up to its limit and raises ``HostTimeout``)."""
        msg, _ = self._recv_internal(timeout)
        while msg is not None and not self._matches_filters(msg):
            msg, _ = self._recv_internal(0)
        return msg

    def drain_frames(self) -> list:
        """Every frame available now, oldest first, as ``(arbitration_id, data, timestamp_us)``
        tuples, without building ``can.Message`` objects: the same
        frames, in the same order, as ``recv(0)`` returns one by one until ``None`` (bus
        filters applied; never waits). The host client's receive path uses it.
        """
        if not self._rx:
            self._read_reports(0)
        rx = self._rx
        if not rx:
            return []
        out = list(rx)
        rx.clear()
        if self._filters is not None:
            out = [f for f in out if self._matches_filters(self._message(f))]
        return out

    def shutdown(self) -> None:
        """Close the HID device."""
        super().shutdown()
        close = getattr(self.device, "close", None)
        if close is not None:
            close()


own_abc_cache(HidGatewayBus)   # compiled by mypyc: see bus._native.own_abc_cache
