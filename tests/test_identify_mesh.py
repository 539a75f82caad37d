"""Identification of the stage-1 mesh amplitude on Fig. 6a (host/identify_mesh.py)."""

from __future__ import annotations

import shutil

import pytest

import host.identify_mesh as im
from plant.params import DEFAULT_PATH, load_parameters


def test_bisection_finds_the_first_amplitude_reaching_the_target(monkeypatch):
    """With a known monotone step response the result is the edge to 0.1 N·m, and every run is logged."""
    edge = 37.26
    monkeypatch.setattr(im, "_peak", lambda sc, a, p: 0.5 + (15.2 if a >= edge else 14.0 * a / edge))
    ident = im.identify_stage1_mesh()
    assert ident.amplitude_nm == pytest.approx(37.3)
    assert ident.peak_pct >= 15.0
    assert ident.bracket_nm[1] - ident.bracket_nm[0] <= 0.1
    assert ident.runs[0] == (0.0, 0.5)


def test_refuses_when_already_above_target(monkeypatch):
    monkeypatch.setattr(im, "_peak", lambda sc, a, p: 20.0)
    with pytest.raises(ValueError, match="already without the mesh line"):
        im.identify_stage1_mesh()


def test_write_changes_one_line_and_reloads(tmp_path):
    """--write replaces only the RA stage-1 amplitude leaf (DEC's identical line untouched)."""
    f = tmp_path / "p.yaml"
    shutil.copy(DEFAULT_PATH, f)
    before = f.read_text().splitlines()
    ident = im.Identification(amplitude_nm=12.3, peak_pct=15.1, bracket_nm=(12.25, 12.3), runs=[(0, 0.5)] * 4)
    im.write_amplitude(f, ident)
    after = f.read_text().splitlines()
    changed = [i for i, (a, b) in enumerate(zip(before, after)) if a != b]
    assert len(before) == len(after) and len(changed) == 1
    p = load_parameters(f)
    assert p.axes["ra"].gear_disturbance["stage1_mesh"]["amplitude_nm"] == 12.3
    assert p.axes["dec"].gear_disturbance["stage1_mesh"]["amplitude_nm"] == 0.0
    src = p.tree["axes"]["ra"]["gear_disturbance"]["stage1_mesh"]["amplitude_nm"]["source"]
    assert "Fig. 6a alone" in src and "12.3 N m" in src


def test_packaged_amplitude_is_what_the_command_identifies():
    """Rerunning the identification on the packaged file reproduces the value written in it (≈8 s)."""
    ident = im.identify_stage1_mesh()
    assert ident.amplitude_nm == load_parameters().axes["ra"].gear_disturbance["stage1_mesh"]["amplitude_nm"]
