"""Heartbeat and PDO periods with jitter, SDO latency (timing checks: docs/conformance.md tolerances)."""

from __future__ import annotations

import pytest

from host.conformance.plugin import intervals, stats

pytestmark = pytest.mark.timing


def _fmt(s: dict) -> str:
    if not s.get("n"):
        return "no intervals"
    return (f"n={s['n']} mean={s['mean'] * 1e3:.3f} ms min={s['min'] * 1e3:.3f} ms "
            f"max={s['max'] * 1e3:.3f} ms p99|dev|={s['p99dev'] * 1e3:.3f} ms")


def _period_check(check, node, id_, period_s, jitter_s, rel, iv):
    s = stats(iv)
    if s["n"]:
        s["p99dev"] = stats([abs(x - period_s) for x in iv])["p99"]
    ok = bool(s["n"]) and (abs(s["mean"] - period_s) <= rel * period_s
                           and s["min"] >= period_s - jitter_s and s["max"] <= period_s + jitter_s
                           and s["p99dev"] <= jitter_s)
    check(id_, node, f"period {period_s * 1e3:g} ms: mean within ±{rel * 100:g} %, every interval and "
          f"p99 |dev| within ±{jitter_s * 1e3:g} ms", _fmt(s), ok, timing=True)


def test_heartbeat_period(node, conf, check, traffic):
    """The CiA heartbeat (0x700 + node) comes at the EDS's 0x1017 period, state 5 OPERATIONAL."""
    tol = conf.docs.tolerances
    period = conf.heartbeat_period_s(node)
    iv = intervals(traffic, 0x700 + node.node_id)
    _period_check(check, node, "timing.heartbeat_period", period, tol.heartbeat_jitter_s,
                  tol.period_mean_rel, iv)
    states = {f.data[0] for f in traffic if f.cob_id == 0x700 + node.node_id}
    check("nmt.heartbeat_state_operational", node, "heartbeat state 0x05 after NMT start",
          sorted(states), states == {0x05})


def test_pdo_periods(node, conf, check, traffic):
    """Every cyclic TPDO (DBC GenMsgCycleTime, = EDS event timer 0x18xx sub 5) comes at that period."""
    tol = conf.docs.tolerances
    periodic = conf.periodic_tpdos(node)
    if not periodic:
        pytest.skip("the node's EDS has no periodic TPDO")
    for cob, ms in sorted(periodic.items()):
        name = conf.docs.message(cob).name if conf.docs.message(cob) is not None else f"0x{cob:03X}"
        _period_check(check, node, f"timing.pdo_period.{name}", ms / 1000.0, tol.pdo_jitter_s,
                      tol.period_mean_rel, intervals(traffic, cob))


def _latency(conf, node, index, n):
    out = []
    for _ in range(n):
        t0 = conf.link.wall()             # the receiver's clock (see plugin.intervals)
        i0 = len(conf.link.frames)
        node.remote.sdo[index].raw
        # every frame since the request: a host that fell behind drains many at once
        answers = [f for f in conf.link.frames[i0:] if f.cob_id == 0x580 + node.node_id]
        out.append(answers[-1].wall - t0)
    return out


def test_sdo_latency(node, conf, check):
    """SDO answer time: expedited upload of 0x1000 (20 times) and segmented upload of the
    device name 0x1008 (5 times), request queued to last answer received."""
    tol = conf.docs.tolerances
    s = stats(_latency(conf, node, 0x1000, 20))
    check("timing.sdo_expedited", node, f"p99 <= {tol.sdo_expedited_s * 1e3:g} ms",
          f"n={s['n']} mean={s['mean'] * 1e3:.3f} ms max={s['max'] * 1e3:.3f} ms p99={s['p99'] * 1e3:.3f} ms",
          s["p99"] <= tol.sdo_expedited_s, timing=True)
    name_len = len(str(node.od[0x1008].default))
    s = stats(_latency(conf, node, 0x1008, 5))
    check("timing.sdo_segmented", node,
          f"whole upload of 0x1008 ({name_len} bytes, segmented) p99 <= {tol.sdo_segmented_s * 1e3:g} ms",
          f"n={s['n']} mean={s['mean'] * 1e3:.3f} ms max={s['max'] * 1e3:.3f} ms p99={s['p99'] * 1e3:.3f} ms",
          name_len > 4 and s["p99"] <= tol.sdo_segmented_s, timing=True)
