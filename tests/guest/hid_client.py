#!/usr/bin/env python3
"""A host program for the ARIES Schmidt CAN-USB gateway, written from docs/usb-gateway.md and
docs/protocol.md alone. It imports nothing from schmidt-fil: only the PyPI ``hid`` package
(ctypes bindings of hidapi; hidraw backend, libhidapi-hidraw.so.0) and the standard library.

Runs against whatever answers at 04d8:003f (in CI: ``python -m host.uhid_gateway`` in the QEMU
guest). Prints one line per check; exit status 0 when every check passed. ``--json FILE``
writes the results and figures.
"""

import argparse
import fcntl
import glob
import json
import os
import struct
import sys
import time

import hid

VID, PID = 0x04D8, 0x003F
SLOT = struct.Struct("<HB8sI")          # id, dlc, data, timestamp_us
STATUS = struct.Struct("<BBBBIIIIIIIIHHHHB")
STATUS_NAMES = ("version flags filters node_id uptime_us rx_frames rx_dropped tx_frames tx_errors "
                "in_reports out_reports out_malformed queue_depth queue_level queue_high_water "
                "hw_overruns last_malformed").split()

results = {"checks": [], "figures": {}}


def check(name, ok, detail=""):
    results["checks"].append({"name": name, "ok": bool(ok), "detail": str(detail)})
    print(f"{'PASS' if ok else 'FAIL'} {name} {detail}", flush=True)
    return ok


def out_report(frames):
    b = bytearray(64)
    b[0], b[1] = 0x01, len(frames)
    for k, (cid, data) in enumerate(frames):
        SLOT.pack_into(b, 4 + 15 * k, cid, len(data), bytes(data).ljust(8, b"\0"), 0)
    return bytes(b)


def parse_in(r):
    assert len(r) == 64, len(r)
    kind, count, flags, seq = r[0], r[1], r[2], r[3]
    frames = []
    for k in range(count):
        cid, dlc, data, ts = SLOT.unpack_from(r, 4 + 15 * k)
        frames.append((cid, data[:dlc], ts))
    return kind, flags, seq, frames


def status(dev):
    r = dev.get_feature_report(0, 65)
    assert len(r) == 65 and r[0] == 0, r
    return dict(zip(STATUS_NAMES, STATUS.unpack_from(r, 1)))


def set_filters(dev, filters):
    b = bytearray(64)
    b[0], b[1] = 0x01, len(filters)
    for i, (fid, mask) in enumerate(filters):
        struct.pack_into("<HH", b, 2 + 4 * i, fid, mask)
    return dev.send_feature_report(b"\0" + bytes(b))


def drain(dev, quiet_ms=30):
    while dev.read(64, quiet_ms):
        pass


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json")
    a = ap.parse_args()
    found = hid.enumerate(VID, PID)
    check("enumerate finds one gateway", len(found) == 1, [(d["path"], d.get("product_string")) for d in found])
    if not found:
        return finish(a)
    info = found[0]
    check("vendor usage page 0xFF00", info.get("usage_page") == 0xFF00, hex(info.get("usage_page") or 0))
    dev = hid.Device(VID, PID)

    st = status(dev)
    check("status report: version 1, node 0x10, queue depth > 0",
          st["version"] == 1 and st["node_id"] == 0x10 and st["queue_depth"] > 0, st)

    # only SDO responses (0x580..0x58F)
    n = set_filters(dev, [(0x580, 0x7F0)])
    check("SET_FILTERS accepted", n == 65, n)
    time.sleep(0.1)
    drain(dev)
    # the health check (docs/protocol.md): SDO upload of 0x1000 from nodes 1-5, then NMT start
    ping = bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])
    nmt_start = bytes([0x01, 0x00])
    ids_other, last_ts, ts_ok, answers, walls = set(), None, True, [], []
    for k in range(2):                    # two health checks
        u0 = status(dev)["uptime_us"]     # gateway clock just before the requests
        t_ping = time.monotonic()
        check(f"OUT report {k + 1} written",
              dev.write(b"\0" + out_report([(0x600 + n, ping) for n in (1, 2, 3, 4)])) == 65
              and dev.write(b"\0" + out_report([(0x605, ping), (0x000, nmt_start)])) == 65)
        got = {}
        deadline = time.monotonic() + 10
        while len(got) < 5 and time.monotonic() < deadline:
            r = dev.read(64, 200)
            if not r:
                continue
            kind, flags, seq, frames = parse_in(r)
            if kind != 0x81:
                ids_other.add(("kind", kind))
            for cid, data, ts in frames:
                if not 0x580 <= cid <= 0x58F:
                    ids_other.add(cid)
                if last_ts is not None and ts < last_ts:
                    ts_ok = False
                last_ts = ts
                after_us = (ts - u0) % 2**32
                if 0x581 <= cid <= 0x585 and len(data) == 8 and data[0] == 0x43 and after_us <= 50_000:
                    got.setdefault(cid, after_us)
        answers.append(got)
        walls.append(time.monotonic() - t_ping)
        time.sleep(0.3)
        drain(dev)
    check("each SDO health check answered by nodes 1-5 within 50 ms (gateway timestamps)",
          all(sorted(g) == [0x581, 0x582, 0x583, 0x584, 0x585] for g in answers),
          [{hex(k): v for k, v in g.items()} for g in answers])
    check("the filter held (only 0x580-0x58F)", not ids_other, ids_other)
    check("timestamps never go back", ts_ok)
    results["figures"]["ping_answer_us_gateway_time"] = [max(g.values()) if g else None for g in answers]
    results["figures"]["ping_to_fifth_answer_wall_ms"] = [round(w * 1e3, 1) for w in walls]
    st = status(dev)
    check("status counts the frames sent on CAN (2 x 6)", st["tx_frames"] == 12 and st["out_malformed"] == 0, st)

    bad = bytearray(64)
    bad[0] = 0x07                                                 # not an OUT report kind
    dev.write(b"\0" + bytes(bad))
    time.sleep(0.2)
    st = status(dev)
    check("malformed OUT report counted (reason 2: kind)",
          st["out_malformed"] == 1 and st["last_malformed"] == 2, st)
    try:
        refused = set_filters(dev, [(0x800, 0x7FF)]) == -1       # id above 0x7FF
    except Exception as exc:                                      # hid raises on -1
        refused = "error" in type(exc).__name__.lower() or "exception" in type(exc).__name__.lower()
    st = status(dev)
    check("bad filter command refused and counted", refused and st["out_malformed"] == 2, st)

    set_filters(dev, [])                                          # everything passes
    drain(dev, 10)
    t0 = time.monotonic()
    per_id, pos_ts = {}, []
    reports = 0
    while len(pos_ts) < 51 and time.monotonic() - t0 < 60:
        r = dev.read(64, 100)
        if r:
            reports += 1
            for cid, _, ts in parse_in(r)[3]:
                per_id[cid] = per_id.get(cid, 0) + 1
                if cid == 0x183:
                    pos_ts.append(ts)
    wall = time.monotonic() - t0
    gaps = sorted((b - a) % 2**32 for a, b in zip(pos_ts, pos_ts[1:]))
    period_us = gaps[len(gaps) // 2] if gaps else 0      # median: robust to reports lost on the way
    results["figures"].update({"position_ra_median_period_us_gateway_time": period_us,
                               "position_ra_frames_per_wall_s": round(len(pos_ts) / wall, 1),
                               "in_reports_per_wall_s": round(reports / wall, 1),
                               "frames_per_wall_s": round(sum(per_id.values()) / wall, 1)})
    check("POSITION_RA (0x183) every 10 ms of gateway time after the filter is cleared",
          len(pos_ts) == 51 and abs(period_us - 10_000) <= 200, f"median period {period_us} us, {len(pos_ts)} frames")
    st = status(dev)
    results["figures"]["status_at_end"] = st
    dev.close()

    # raw hidraw: the same device as /dev/hidrawN, a plain read of one 64-byte report
    node = None
    for path in glob.glob("/sys/class/hidraw/hidraw*/device/uevent"):
        with open(path) as f:
            if f"HID_ID=0003:{VID:08X}:{PID:08X}" in f.read():
                node = "/dev/" + path.split("/")[4]
    ok = False
    if node:
        fd = os.open(node, os.O_RDWR)
        try:
            r = b""
            t = time.monotonic()
            while not r and time.monotonic() - t < 5:
                r = os.read(fd, 64)
            ok = len(r) == 64 and r[0] == 0x81
            # HIDIOCGFEATURE(65) = _IOC(READ|WRITE, 'H', 0x07, 65)
            buf = bytearray(65)
            fcntl.ioctl(fd, (3 << 30) | (65 << 16) | (ord("H") << 8) | 0x07, buf)
            ok = ok and buf[0] == 0 and buf[1] == 1 and buf[4] == 0x10
        finally:
            os.close(fd)
    check("raw /dev/hidrawN: read a 64-byte IN report and the status ioctl", ok, node)
    return finish(a)


def finish(a):
    ok = all(c["ok"] for c in results["checks"]) and results["checks"]
    results["ok"] = bool(ok)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
