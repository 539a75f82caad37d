"""Bit-serial CAN 2.0A frame length (CRC-15 and bit stuffing), compiled with numba when available.

:func:`bus.network.frame_bits` needs the exact stuffed length of every frame it puts on the
wire; status frames change their data every period, so its cache misses for most of them. This
kernel walks the frame bit by bit as a CAN controller does: ≈ 0.5 µs per frame compiled, against
≈ 5–10 µs for the table-driven interpreted version it replaces on the hot path
(``bus.network._frame_bits_tables``, kept as the fallback). Like :mod:`plant.kernel` it is plain
Python that numba compiles (cached on disk, ``cache=True``); with ``SCHMIDT_FIL_JIT=0`` or without
numba, :data:`JIT` is False and ``frame_bits`` uses the tables instead (the bit loop interpreted
would be slower than the tables). tests/test_bus_network.py checks both against a bit-by-bit
reference written from ISO 11898-1.

Nothing here reads the clock or keeps state between calls.
"""

from __future__ import annotations

import os

__all__ = ["JIT", "frame_bits_kernel"]

_jit_wanted = os.environ.get("SCHMIDT_FIL_JIT", "1").strip() not in ("0", "false", "no", "off")
try:
    if not _jit_wanted:
        raise ImportError("disabled by SCHMIDT_FIL_JIT=0")
    from numba import njit as _njit

    def _jit(fn):
        return _njit(cache=True)(fn)

    JIT = True
except ImportError:
    def _jit(fn):
        return fn

    JIT = False

#: CAN CRC-15 generator polynomial (ISO 11898-1: x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1).
CRC15_POLY = 0x4599


@_jit
def frame_bits_kernel(arbitration_id, n, data_hi, data_lo):
    """Bits on the wire of a CAN 2.0A data frame, stuff bits and the 3-bit intermission included.

    Parameters
    ----------
    arbitration_id : int
        11-bit identifier (not checked here: :func:`bus.network.frame_bits` checks it).
    n : int
        Data length, 0..8 bytes (the DLC).
    data_hi, data_lo : int
        The data bytes as one big-endian integer of ``8 n`` bits, split into its bits 32..63
        and 0..31.

    Returns
    -------
    int
        SOF + identifier + RTR + IDE + r0 + DLC + data + CRC-15 (34 + 8 n bits) plus the stuff
        bits of that span, plus CRC delimiter, ACK slot, ACK delimiter, 7 EOF and 3 intermission
        bits (13).
    """
    ndata = 8 * n
    nb = 19 + ndata                  # SOF .. end of data
    total = nb + 15                  # .. end of CRC
    crc = 0
    run_val = 2                      # no run yet
    run_len = 0
    stuffs = 0
    for i in range(total):
        if i < nb:
            k = nb - 1 - i           # bit position from the end of the data field
            if k < ndata:
                b = (data_hi >> (k - 32)) & 1 if k >= 32 else (data_lo >> k) & 1
            else:
                kk = k - ndata       # header: SOF(18) id(17..7) RTR IDE r0 (6..4) DLC(3..0)
                if kk >= 18:
                    b = 0
                elif kk >= 7:
                    b = (arbitration_id >> (kk - 7)) & 1
                elif kk >= 4:
                    b = 0
                else:
                    b = (n >> kk) & 1
            top = ((crc >> 14) & 1) ^ b
            crc = (crc << 1) & 0x7FFF
            if top:
                crc ^= CRC15_POLY
        else:
            b = (crc >> (total - 1 - i)) & 1
        if b == run_val:
            run_len += 1
        else:
            run_val = b
            run_len = 1
        if run_len == 5:             # five equal bits: a stuff bit of the other value follows
            stuffs += 1
            run_val ^= 1
            run_len = 1
    return total + stuffs + 13
