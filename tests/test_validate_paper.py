"""`schmidt-fil validate-paper` works end to end (shortened durations: a structure check, not the numbers)."""

from __future__ import annotations

import json

import pytest

from host.cli import main
from host.validate_paper import ROW_FIELDS, RUNS


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("vp")
    assert main(["validate-paper", "--out", str(out), "--duration-scale", "0.08"]) == 0
    return out


def test_writes_json_and_markdown_with_every_row(short_run):
    """validation.json has the row fields, every run, and counts only predictions; validation.md says it is short."""
    doc = json.loads((short_run / "validation.json").read_text())
    assert doc["duration_scale"] == 0.08
    assert set(doc["runs"]) == set(RUNS)
    rows = doc["rows"]
    assert len(rows) == 11
    for r in rows:
        assert set(ROW_FIELDS) <= set(r)
        assert r["agrees"] in (True, False, None)
        assert r["cause"]
        assert (r["agrees"] is None) == (r["role"] != "prediction")
    preds = [r for r in rows if r["role"] == "prediction"]
    assert doc["predictions"] == len(preds) == 9
    assert doc["agree"] == sum(1 for r in preds if r["agrees"])
    # the identification figure is never counted as a prediction
    assert all("6a" not in r["figure"] for r in preds)
    md = (short_run / "validation.md").read_text()
    assert "structure check, not a validation" in md
    assert md.count("\n| ") >= len(rows)
    for name in RUNS:
        assert (short_run / "runs" / name / "report.json").exists()


def test_every_report_segment_has_tick_and_10ms_fields(short_run):
    for name in RUNS:
        rep = json.loads((short_run / "runs" / name / "report.json").read_text())
        for s in rep["segments"]:
            if s["peak_error_pct"] is None:
                continue
            for k in ("peak_error_tick_pct", "rms_error_tick_pct", "peak_error_10ms_pct", "rms_error_10ms_pct",
                      "disturbance_lines", "forced_line"):
                assert k in s, (name, s["name"], k)


def test_bad_scale_is_refused(tmp_path, capsys):
    assert main(["validate-paper", "--out", str(tmp_path), "--duration-scale", "2"]) == 1
    assert "duration_scale must be in (0, 1]" in capsys.readouterr().err
