"""SDO server for simulated time: canopen's :class:`canopen.sdo.SdoServer` with the bus kept safe.

canopen's server does the protocol (expedited and segmented upload/download, toggle bit, abort
codes; block transfer is answered with a normal upload or an abort, as CiA 301 allows). Three
things are changed, each because the original would let a frame from the bus raise into the
board or hide an emulator bug:

* a request whose DLC is not 8 (CiA 301 §7.2.4.3: SDO frames are 8 bytes) raises
  :class:`bus.errors.MalformedFrame` for the board to count — canopen would raise
  ``struct.error`` from ``unpack_from``;
* a segment request with no transfer in progress is aborted with 0x05040001 (invalid command
  specifier) — canopen raises ``TypeError``/``AttributeError`` on its empty buffer, and its
  ``abort`` then fails packing ``None`` as the index;
* a segmented download is checked (object exists, writable) at its initiation, where CiA 301
  expects the abort; canopen checks only after the last segment;
* a block download request is aborted (0x05040001) here; canopen does the same but logs an
  error for every such frame, which a fuzzed bus turns into stderr spam;
* only ``SdoAbortedError`` becomes an abort on the wire. canopen also turns *any* exception into
  a general-error abort and logs it; here any other exception is an emulator bug and propagates
  (the scheduler stops the run naming the board), as docs/architecture.md requires.

Requests are served only while ``gate()`` is true (NMT PRE-OPERATIONAL or OPERATIONAL).
"""

from __future__ import annotations

import struct
from typing import Callable, Optional

from canopen.sdo import SdoAbortedError, SdoServer
from canopen.sdo.constants import (ABORT_INVALID_COMMAND_SPECIFIER, ABORT_WRITE_READONLY,
                                   EXPEDITED, NO_MORE_DATA, REQUEST_ABORTED,
                                   REQUEST_BLOCK_DOWNLOAD, REQUEST_BLOCK_UPLOAD, REQUEST_DOWNLOAD,
                                   REQUEST_SEGMENT_DOWNLOAD, REQUEST_SEGMENT_UPLOAD,
                                   REQUEST_UPLOAD, RESPONSE_ABORTED)

from bus.errors import MalformedFrame

__all__ = ["SimSdoServer"]


class SimSdoServer(SdoServer):
    """canopen's SDO server, fed by ``network.notify``, robust against any request frame.

    Parameters
    ----------
    rx_cobid, tx_cobid : int
        0x600 + node and 0x580 + node.
    node : canopen.LocalNode
        The node whose ``get_data``/``set_data`` serve the objects.
    gate : callable
        ``gate() -> bool``: serve requests now (False in NMT STOPPED).
    """

    def __init__(self, rx_cobid: int, tx_cobid: int, node, gate: Callable[[], bool]) -> None:
        super().__init__(rx_cobid, tx_cobid, node)
        self._gate = gate
        self._transfer: Optional[str] = None      # None, "upload" or "download" (segmented)
        self.requests = 0
        self.aborts_sent = 0
        self.ignored = 0                          # requests while not served (NMT STOPPED)

    def on_request(self, can_id, data, timestamp):
        if not self._gate():
            self.ignored += 1
            return
        if len(data) != 8:
            raise MalformedFrame(f"SDO request 0x{can_id:03X}", "DLC", "8", len(data))
        self.requests += 1
        command = data[0]
        ccs = command & 0xE0
        try:
            if ccs == REQUEST_UPLOAD or ccs == REQUEST_BLOCK_UPLOAD:
                self._buffer, self._transfer = None, None
                self.init_upload(data)
                if self._buffer:
                    self._transfer = "upload"
            elif ccs == REQUEST_DOWNLOAD:
                self._buffer, self._transfer = None, None
                _, self._index, self._subindex = struct.unpack_from("<BHB", data)
                if not command & EXPEDITED:       # check at initiation, not after all segments
                    obj = self._node._find_object(self._index, self._subindex)
                    if not obj.writable:
                        raise SdoAbortedError(ABORT_WRITE_READONLY)
                self.init_download(data)
                if self._buffer is not None:
                    self._transfer = "download"
            elif ccs == REQUEST_SEGMENT_UPLOAD:
                if self._transfer != "upload":
                    raise SdoAbortedError(ABORT_INVALID_COMMAND_SPECIFIER)
                self.segmented_upload(command)
                if not self._buffer:
                    self._transfer = None
            elif ccs == REQUEST_SEGMENT_DOWNLOAD:
                if self._transfer != "download":
                    raise SdoAbortedError(ABORT_INVALID_COMMAND_SPECIFIER)
                if command & NO_MORE_DATA:
                    self._transfer = None            # ends whether the write succeeds or not
                self.segmented_download(command, data)
            elif ccs == REQUEST_ABORTED:
                self._transfer = None
                self.request_aborted(data)
            elif ccs == REQUEST_BLOCK_DOWNLOAD:
                # not supported (CiA 301 allows it): abort as canopen's block_download does, but
                # without its logger.error, so a request from the bus prints nothing
                self._transfer = None
                _, self._index, self._subindex = struct.unpack_from("<BHB", data)
                raise SdoAbortedError(ABORT_INVALID_COMMAND_SPECIFIER)
            else:
                raise SdoAbortedError(ABORT_INVALID_COMMAND_SPECIFIER)
        except SdoAbortedError as exc:
            self.abort(exc.code)

    def abort(self, abort_code: int = 0x08000000) -> None:
        """Send an abort for the current (or last) index/sub-index and end any transfer."""
        self._transfer = None
        self._buffer = None
        self.aborts_sent += 1
        data = struct.pack("<BHBL", RESPONSE_ABORTED, self._index or 0, self._subindex or 0,
                           abort_code)
        self.send_response(data)
