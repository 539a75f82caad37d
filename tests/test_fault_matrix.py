"""The fault matrix of issue 11: every fault kind of the scenario fault table (host/faults.py)
× every board of the basic network it applies to, run through a scenario, with the firmware's
reaction and the host's log lines that docs/faults.md ("Fault kinds for scenarios") documents.

Each case is a short RA track (4 s simulated) with the fault at 0.5 s after power-on (0.2 s for
``host_loss``, so that its 3 s of silence pass the 2 s host watchdog); the expectations are
written from the docs table, not from what the code printed.
"""

from __future__ import annotations

import pytest

from boards.registry import BOARDS, NETWORKS
from host.faults import FAULTS
from host.runner import run_scenario
from host.scenario import parse_scenario

BASIC = NETWORKS["basic"]
AXIS_OF_READER = {"ra-reader": "ra-axis", "dec-reader": "dec-axis"}

#: parameters each kind is run with (docs/scenarios.md)
PARAMS = {
    "endat_bit_flip": "bit: 7",
    "focus_stall": "halfsteps: 7",
    "can_error": "probability: 0.3, duration_s: 1.0",
    "frame_loss": "probability: 0.5, duration_s: 1.0",
    "babbling_node": "duration_s: 0.5",
    "host_loss": "duration_s: 3.0",
}


def _cases():
    out = []
    for kind, fk in FAULTS.items():
        if fk.board in ("none", "optional"):
            out.append((kind, None))
        if fk.board == "none":
            continue
        for name in BASIC:
            spec, _ = BOARDS[name]
            if fk.board_kinds is None or spec.kind in fk.board_kinds:
                out.append((kind, name))
                if fk.board == "optional":
                    break                      # one board is enough for the optional-board kinds
    return out


CASES = _cases()


def _run(kind, board, tmp_path):
    at = 0.2 if kind == "host_loss" else 0.5
    extra = PARAMS.get(kind, "")
    fault = f"{{at_s: {at}, kind: {kind}" + (f", board: {board}" if board else "") + (f", {extra}" if extra else "") + "}"
    focus = ", focus_halfsteps: 300" if kind == "focus_stall" else ""
    text = (f"name: matrix\nseed: 5\nplant: {{preload: low}}\nfaults:\n  - {fault}\n"
            f"segments:\n  - {{name: t, axis: ra, mode: track, duration_s: 4{focus}}}\n")
    out = tmp_path / "out"
    rep = run_scenario(parse_scenario(text, str(tmp_path / "m.yaml")), out, plots=False).report
    errors = [line.split(None, 1)[1] for line in (out / "errors.log").read_text().splitlines()
              if line and not line.startswith("#")]
    return rep, errors


def _has(errors, board, word):
    return any(e.startswith(f"{board} {word}") for e in errors)


def test_every_kind_of_the_fault_table_is_in_the_matrix():
    assert {k for k, _ in CASES} == set(FAULTS)


@pytest.mark.parametrize("kind,board", CASES, ids=[f"{k}-{b or 'any'}" for k, b in CASES])
def test_fault_reaction_and_host_logs(kind, board, tmp_path):
    rep, errors = _run(kind, board, tmp_path)
    boards, bus = rep["boards"], rep["bus_stats"]
    canopen = board is not None and BOARDS[board][0].canopen
    assert _has(errors, board or "bus", f"injected-fault {kind}"), errors[:5]
    if kind == "endat_bit_flip":             # CRC error counted, FAULT 2; crc_errors
        assert boards[board]["crc_errors"] >= 1 and _has(errors, board, "endat_crc")
    elif kind == "malformed_frame":          # frame counted, FAULT 1; malformed_frames
        assert boards[board]["malformed_frames"] >= 1 and _has(errors, board, "malformed_frame")
    elif kind == "board_reset":              # boots again (watchdog cause), FAULT 5; state line, resets
        assert boards[board]["resets"] >= 1 and boards[board]["reset_cause"] == "watchdog"
        if canopen:                          # the host starts the rebooted node again (NMT master)
            assert _has(errors, board, "watchdog") and _has(errors, board, "rebooted")
            assert boards[board]["state"] == "OPERATIONAL"
    elif kind == "remove_board":             # heartbeat-lost <= 2.6 s later; report state LOST
        lost = [board] if canopen else [n for n in BASIC if BOARDS[n][0].canopen]   # the gateway: every board
        for n in lost:
            assert boards[n]["state"] == "LOST", (n, boards[n]["state"])
        if canopen:
            assert _has(errors, board, "heartbeat-lost")
    elif kind == "focus_stall":              # missed steps counted, FAULT 6 with the true count
        f = boards["focus"]
        assert f["missed_steps"] == f["plant_lost_halfsteps"] == 7 and _has(errors, "focus", "step_loss")
    elif kind == "can_error":                # error frames, retransmission, TEC/REC
        assert bus["error_frames"] > 0 and bus["error_bits"] > 0
        if board:
            assert bus["error_counters"][board]["retransmissions"] > 0
    elif kind == "frame_loss":               # missed frames
        lost = sum(c["frames_lost"] for c in bus["error_counters"].values())
        assert lost > 0
        if board:
            assert bus["error_counters"][board]["frames_lost"] == lost
    elif kind == "babbling_node":            # lower-priority frames wait: latency in bus_stats
        assert bus["frames_by_id"].get("UNKNOWN_0x001", 0) > 100
        assert max(bus["max_latency_us"].values()) > 1_000
    elif kind == "bus_off":                  # bus-off; its heartbeats stop: heartbeat-lost, LOST
        assert bus["error_counters"][board]["bus_off_count"] >= 1
        assert boards[board]["can"]["error_state"] == "bus-off"
        if canopen:
            assert boards[board]["state"] == "LOST" and _has(errors, board, "heartbeat-lost")
        else:                                # the gateway: the host's frames (its heartbeat) stop
            assert _has(errors, "ra-axis", "host_timeout") and _has(errors, "dec-axis", "host_timeout")
    elif kind == "host_loss":                # the host watchdog (2 s) stops the axes: FAULT 10
        assert _has(errors, "ra-axis", "host_timeout") and _has(errors, "dec-axis", "host_timeout")
    elif kind == "reader_loss":              # the axis stops and refuses motion (FAULT 9), LOST
        assert _has(errors, AXIS_OF_READER[board], "reader_lost")
        assert boards[board]["state"] == "LOST" and _has(errors, board, "heartbeat-lost")
    else:                                    # a kind added to the table needs its row here
        pytest.fail(f"no expectation for fault kind {kind!r}: add it from docs/faults.md")
