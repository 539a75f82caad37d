"""The USB cable and host controller in simulated time: one 1 ms frame event that services a HID
interface's endpoints the way a PC's USB host does (docs/usb-gateway.md).

Every frame (USB 2.0 §5.7.4: full speed, 1 ms, bInterval = 1) the host sends SOF, delivers at
most one queued OUT report (NAKed → retried next frame) and, while the device is open, polls the
IN endpoint once. Reports it takes go to :attr:`UsbHostPort.received` (the PC driver's buffer,
bounded like hidraw's 64-report list) or to ``on_in_report``. While that buffer is full the port
does not poll: a PC that does not read leaves the device's IN endpoint armed, so the device's
own queue fills (assumed model of "the PC falls behind"; a real hidraw keeps polling and drops
the newest report in the kernel, see docs/usb-gateway.md).

Control transfers (feature reports) complete at once in simulated time (their ≤ 1 ms duration
is not modelled).

**Idle frames cost nothing.** A frame in which nothing can happen (no OUT report queued, the
device idle: its :meth:`host_idle` is true — for the gateway, an empty CAN→PC queue, no flags to
report, nothing armed) changes only the frame and NAK counters. After such a frame the port
stops its event and the device wakes it (``on_wake``) when something arrives: a CAN frame
(``after_now=False``: the frame at this instant, if it is a boundary, still takes it, as the
always-running event at ``PRIO_USB`` would) or a host-side request (``after_now=True``). The idle
frames are counted when the port wakes (and in :meth:`counters`), so reports, their times and
the counters are those of a frame event that never stops (``tests/test_usb_gateway.py`` checks
it against an always-running port). Nothing here reads the wall clock; the scheduler's frame event is the only
time source. The device is any object with the ``host_*`` methods of
:class:`boards.usb_hid.UsbHidInterface` (bus/ does not import boards/).
"""

from __future__ import annotations

from collections import deque
from typing import Callable, Deque, Final, Optional, Tuple

from bus.scheduler import PRIO_HOST, Event, Scheduler

__all__ = ["UsbHostPort", "FRAME_PERIOD_US", "HIDRAW_BUFFER_REPORTS", "PRIO_USB"]

#: Priority of the frame event: after the boards (ISRs, CAN delivery, background loops) at the
#: same instant, before the host's own events (``PRIO_HOST``), so a host event at a frame
#: boundary sees that frame's reports.
PRIO_USB: Final = PRIO_HOST - 1

#: Full-speed frame period and interrupt-endpoint interval, µs (USB 2.0 §5.7.4).
FRAME_PERIOD_US: Final = 1_000
#: Reports a reader may leave unread before the host stops polling (Linux hidraw keeps a list
#: of 64 reports per open file, drivers/hid/hidraw.c HIDRAW_BUFFER_SIZE).
HIDRAW_BUFFER_REPORTS: Final = 64
#: OUT reports a writer may queue before ``write`` fails (assumed: usbhid's output FIFO holds
#: 256 reports; a smaller bound makes a stalled gateway visible sooner).
OUT_QUEUE_REPORTS: Final = 64


class UsbHostPort:
    """Host side of one USB HID device: the 1 ms frame event, OUT queue, IN buffer.

    Parameters
    ----------
    scheduler : Scheduler
        The simulation clock (the frame event runs at :data:`PRIO_USB` on whole milliseconds).
    device : UsbHidInterface-like
        The device's interface (``host_sof``, ``host_poll_in``, ``host_out``,
        ``host_get_feature``, ``host_set_feature``).
    rx_buffer_reports : int
        Size of :attr:`received`; no polling while it is full.
    out_queue_reports : int
        Size of the OUT queue; :meth:`write` returns False when it is full.
    name : str
        Owner name in scheduler errors.
    """

    def __init__(self, scheduler: Scheduler, device, *, rx_buffer_reports: int = HIDRAW_BUFFER_REPORTS,
                 out_queue_reports: int = OUT_QUEUE_REPORTS, name: str = "usb-host") -> None:
        self.scheduler = scheduler
        self.device = device
        self.rx_buffer_reports = int(rx_buffer_reports)
        self.out_queue_reports = int(out_queue_reports)
        self.name = name
        #: IN reports taken and not yet read: ``(time_us, report)``
        self.received: Deque[Tuple[int, bytes]] = deque()
        self._out: Deque[Tuple[int, bytes]] = deque()     # (time written, report)
        #: called with ``(report, now_us)`` for each IN report taken, instead of buffering it
        self.on_in_report: Optional[Callable[[bytes, int], None]] = None
        #: called (no arguments) after an IN report is put in :attr:`received`: a reader that
        #: waits for reports (a PC thread blocked in ``read``) wakes at once
        self.on_buffered: Optional[Callable[[], None]] = None
        self.opened = False
        self.frames = 0
        self.in_reports = 0
        self.out_reports = 0
        self.out_rejected = 0
        self.polls_skipped = 0
        #: wait of the OUT reports the device accepted, from ``write`` to the device taking it [µs]
        self.out_wait_sum_us = 0
        self.out_wait_max_us = 0
        #: frames the port did not run because nothing could happen in them (counted in frames)
        self.idle_frames = 0
        self._can_idle = hasattr(device, "host_idle")
        if self._can_idle:
            device.on_wake = self._wake
        self._last_us: Optional[int] = None       # last frame counted while the event sleeps
        start = (scheduler.now_us // FRAME_PERIOD_US + 1) * FRAME_PERIOD_US
        self._event: Optional[Event] = scheduler.call_every(FRAME_PERIOD_US, self._frame, start_us=start,
                                           priority=PRIO_USB, owner=name)

    def open(self) -> None:
        """A program opened the device: the host starts polling the IN endpoint."""
        self._catch_up(self.scheduler.now_us)
        self.opened = True

    def close(self) -> None:
        """The last reader closed the device: polling stops, unread reports are discarded."""
        self._catch_up(self.scheduler.now_us)
        self.opened = False
        self.received.clear()

    # -- idle frames ---------------------------------------------------------------------------
    def _catch_up(self, upto_us: int) -> None:
        """Count the idle frames at the boundaries after the last one counted, up to ``upto_us``
        (included), while the event sleeps."""
        if self._last_us is None:
            return
        last = upto_us // FRAME_PERIOD_US * FRAME_PERIOD_US
        n = (last - self._last_us) // FRAME_PERIOD_US
        if n > 0:
            self.frames += n
            self.idle_frames += n
            if self.opened:
                self.device.host_idle_frames(n)   # the IN token of each is NAKed
            self._last_us = last

    def _wake(self, after_now: bool) -> None:
        """Something may happen in the next frame: restart the frame event (no-op when awake).
        ``after_now`` false: a boundary at this instant is still to come (the caller runs
        before :data:`PRIO_USB`)."""
        if self._last_us is None or self._event is None:
            return
        now = self.scheduler.now_us
        self._catch_up(now if after_now else now - 1)
        start = self._last_us + FRAME_PERIOD_US
        self._last_us = None
        self._event = self.scheduler.call_every(FRAME_PERIOD_US, self._frame, start_us=start,
                                                priority=PRIO_USB, owner=self.name)

    def write(self, report: bytes) -> bool:
        """Queue an OUT report (sent at the next frames); False if the queue is full."""
        if len(self._out) >= self.out_queue_reports:
            self.out_rejected += 1
            return False
        self._out.append((self.scheduler.now_us, bytes(report)))
        self._wake(True)
        return True

    @property
    def out_pending(self) -> int:
        """OUT reports queued and not yet accepted by the device."""
        return len(self._out)

    def get_feature(self) -> Optional[bytes]:
        """GET_REPORT(Feature); None if the device stalled."""
        return self.device.host_get_feature()

    def set_feature(self, report: bytes) -> bool:
        """SET_REPORT(Feature); False if the device stalled."""
        return self.device.host_set_feature(bytes(report))

    def _frame(self, now_us: int) -> None:
        self._service(now_us)
        if (self._can_idle and not self._out and self.device.host_idle()
                and (not self.opened or self.on_in_report is not None
                     or len(self.received) < self.rx_buffer_reports)):
            self.scheduler.cancel(self._event)      # nothing can happen until a wake
            self._last_us = now_us

    def _service(self, now_us: int) -> None:
        self.frames += 1
        dev = self.device
        dev.host_sof(now_us)
        if self._out and dev.host_out(self._out[0][1], now_us):
            wait = now_us - self._out.popleft()[0]
            self.out_reports += 1
            self.out_wait_sum_us += wait
            if wait > self.out_wait_max_us:
                self.out_wait_max_us = wait
        if not self.opened:
            return
        if self.on_in_report is None and len(self.received) >= self.rx_buffer_reports:
            self.polls_skipped += 1
            return
        report = dev.host_poll_in(now_us)
        if report is None:
            return
        self.in_reports += 1
        if self.on_in_report is not None:
            self.on_in_report(report, now_us)
        else:
            self.received.append((now_us, report))
            if self.on_buffered is not None:
                self.on_buffered()

    def counters(self) -> dict:
        """The PC side of the link for the report: frames, reports each way, OUT reports refused
        (queue full), polls skipped (the reader's buffer full) and the wait of the OUT reports
        from ``write`` to the device [µs]."""
        self._catch_up(self.scheduler.now_us)
        n = self.out_reports
        return {"usb_frames": self.frames, "idle_frames": self.idle_frames, "in_reports": self.in_reports, "out_reports": n,
                "out_rejected": self.out_rejected, "polls_skipped": self.polls_skipped,
                "out_wait_us": {"mean": round(self.out_wait_sum_us / n, 1) if n else None,
                                "max": self.out_wait_max_us if n else None}}

    def shutdown(self) -> None:
        """Unplug: the frame event stops."""
        self._catch_up(self.scheduler.now_us)
        self.scheduler.cancel(self._event)
        self._event = None
        self.opened = False
