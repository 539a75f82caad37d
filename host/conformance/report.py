"""conformance.json and conformance.md (per check: id, node, documented, observed, pass)."""

from __future__ import annotations

import json
import time
from collections import defaultdict
from dataclasses import asdict
from pathlib import Path

__all__ = ["write_reports", "summary"]


def summary(records) -> dict:
    """Counts of passed / failed / reported-only checks."""
    asserted = [r for r in records if r.asserted]
    return {"checks": len(records),
            "passed": sum(1 for r in asserted if r.passed),
            "failed": sum(1 for r in asserted if not r.passed),
            "reported_only": sum(1 for r in records if not r.asserted),
            "reported_only_outside_tolerance": sum(1 for r in records if not r.asserted and not r.passed)}


def write_reports(out: Path, conf) -> None:
    """Write ``out/conformance.json`` and ``out/conformance.md`` from the session's records."""
    out.mkdir(parents=True, exist_ok=True)
    link = conf.link
    nodes = conf._nodes or []
    head = {
        "bus": link.description if link is not None else "not opened",
        "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "timing": "asserted" if conf.timing_asserted else "reported, not asserted",
        "motion": "allowed" if conf.motion_allowed else "not allowed (checks that move skipped)",
        "tolerances": asdict(conf.docs.tolerances),
        "nodes": {str(n.node_id): n.kind.name for n in nodes},
        "clock": link.clock_summary() if link is not None else None,
        "summary": summary(conf.records),
    }
    if conf.lateness:
        head["pacer_lateness"] = conf.lateness
    head["reruns_host_lapsed"] = list(conf.reruns)
    doc = dict(head, checks=[{"id": r.id, "node": r.node, "documented": r.documented,
                              "observed": r.observed, "pass": r.passed, "kind": r.kind,
                              "asserted": r.asserted, "test": r.test} for r in conf.records])
    (out / "conformance.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")

    s = head["summary"]
    lines = ["# schmidt-fil conformance report", "",
             f"- bus: {head['bus']}", f"- written: {head['written']}",
             f"- timing checks: {head['timing']}", f"- motion: {head['motion']}",
             f"- nodes: " + (", ".join(f"{k} ({v})" for k, v in head["nodes"].items()) or "none"),
             f"- clock of the waits: {head['clock']}",
             f"- **{s['passed']} passed, {s['failed']} failed** of {s['checks']} checks"
             + (f"; {s['reported_only']} timing checks reported only "
                f"({s['reported_only_outside_tolerance']} outside tolerance)" if s["reported_only"] else ""),
             ""]
    if conf.lateness:
        lines += [f"- pacer lateness of the emulator: {conf.lateness}", ""]
    if conf.reruns:
        lines += ["## Run again: the host's own heartbeat lapsed", "",
                  "A test that failed while a device reported the host silent (EMCY HEARTBEAT_LOST "
                  "naming the host, or HOST_TIMEOUT), without the test silencing it, was run again; "
                  "the failed attempt's checks are not counted (docs/conformance.md, \"The host's own "
                  "heartbeat\").", "",
                  "| test | attempt | the devices said | host's longest gap between beats (wall) | failed then |",
                  "|---|---|---|---|---|"]
        for r in conf.reruns:
            lines.append(f"| {_md(r['test'])} | {r['attempt']} | {_md('; '.join(r['lapses']))} | "
                         f"{r['host_longest_beat_gap_wall_s'] * 1e3:.0f} ms | {_md('; '.join(r['failed']))} |")
        lines.append("")
    failed = [r for r in conf.records if not r.passed]
    if failed:
        lines += ["## Outside the documents", "", "| node | check | documented | observed | |",
                  "|---|---|---|---|---|"]
        for r in failed:
            lines.append(f"| {r.node} | {r.id} | {_md(r.documented)} | {_md(r.observed)} | "
                         f"{'FAIL' if r.asserted else 'reported'} |")
        lines.append("")
    by_node = defaultdict(list)
    for r in conf.records:
        by_node[r.node].append(r)
    for nid in sorted(by_node, key=lambda x: -1 if x is None else x):
        kind = head["nodes"].get(str(nid), "")
        lines += [f"## Node {nid} {kind}".rstrip(), "", "| check | documented | observed | result |",
                  "|---|---|---|---|"]
        for r in by_node[nid]:
            res = ("OK" if r.passed else "FAIL") if r.asserted else ("ok (reported)" if r.passed else "outside (reported)")
            lines.append(f"| {r.id} | {_md(r.documented)} | {_md(r.observed)} | {res} |")
        lines.append("")
    (out / "conformance.md").write_text("\n".join(lines), encoding="utf-8")


def _md(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")
