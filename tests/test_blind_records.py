"""Tests of the blind record generator (plant/calibration/blind_records.py).

The module is loaded from its file so that the test depends on nothing else
in the project; all physical checks are derived from the generator's own
equations (LuGre friction, dead-zone gear, encoder quantisation).
"""

from __future__ import annotations

import ast
import importlib.util
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

_PATH = Path(__file__).resolve().parents[1] / "plant" / "calibration" / "blind_records.py"


def _load():
    name = "_blind_records_under_test"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, _PATH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


br = _load()


@pytest.fixture(scope="module")
def draws():
    """Parameters of all 60 blind seeds (no simulation)."""
    return {s: br._draw(s, br.plan()[s % 60]) for s in br.BLIND_SEEDS}


def _first_seed(kind_ok, hidden=(), seeds=range(1000, 1200)):
    for s in seeds:
        p = br._draw(s, hidden)
        if kind_ok(p):
            return s, p
    raise AssertionError("no seed found")


# --------------------------------------------------------------- independence
def test_imports_only_allowed_modules():
    tree = ast.parse(_PATH.read_text())
    allowed = {"__future__", "math", "dataclasses", "typing", "json", "numpy", "scipy", "numba"}
    seen = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                seen.add(a.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "relative import"
            seen.add(node.module.split(".")[0])
    assert seen <= allowed, seen - allowed
    assert not seen & {"plant", "host", "bus", "boards"}
    src = _PATH.read_text()
    assert "importlib" not in src and "__import__" not in src


# --------------------------------------------------------------- plan
def test_plan_counts():
    pl = br.plan()
    assert len(pl) == 60 and len(br.BLIND_SEEDS) == 60
    assert br.BLIND_SEEDS == tuple(range(60))
    c = Counter(pl)
    for k in br.LIBRARY_KINDS:
        assert c[(k,)] == 5
    pairs = [h for h in pl if len(h) == 2]
    assert len(pairs) == 8
    for a, b in pairs:
        assert a != b and a in br.LIBRARY_KINDS and b in br.LIBRARY_KINDS
        assert {a, b} != {"backlash", "presliding"}
    assert c[()] == 10
    ool = [h for h in pl if len(h) == 1 and h[0] in br.OUT_OF_LIBRARY]
    assert len(ool) == 60 - 30 - 8 - 10
    assert len(br.OUT_OF_LIBRARY) >= 4
    for k in br.OUT_OF_LIBRARY:
        assert c[(k,)] >= 2
    assert not set(br.OUT_OF_LIBRARY) & set(br.LIBRARY_KINDS)
    assert br.plan(70)[65] == pl[5]


_TRUTH_KEYS = {
    "asymmetric_friction": {"viscous_pos_nm_s_rad", "viscous_neg_nm_s_rad"},
    "position_periodic": {"period_rad", "amplitude_nm"},
    "gravity_imbalance": {"amplitude_nm"},
    "presliding": {"sigma0_nm_rad"},
    "backlash": {"width_rad"},
    "time_periodic": {"frequency_hz", "amplitude_nm"},
}


def test_truth_and_ranges(draws):
    for s, p in draws.items():
        hidden = p["hidden"]
        truth = p["_truth"]
        lib = [h for h in hidden if h in br.LIBRARY_KINDS]
        assert set(truth) == set(lib)
        for k in lib:
            assert set(truth[k]) == _TRUTH_KEYS[k]
            assert all(v > 0 and math.isfinite(v) for v in truth[k].values())
        fc = p["coulomb_nm"]
        assert 0.5 <= fc <= 20 and 0.5 <= p["inertia_kg_m2"] <= 20
        assert 1.05 <= p["static_over_coulomb"] <= 1.6
        assert 1e-4 <= p["stribeck_velocity_rad_s"] <= 5e-3
        assert 1.0 <= p["stribeck_exponent"] <= 2.0
        assert 1.0 <= p["viscous_nm_s_rad"] <= 200.0
        assert abs(p["offset_nm"]) <= 0.1 * fc
        assert 200 <= p["fs_log_hz"] <= 1000 and 500 <= p["f_ctrl_hz"] <= 2000
        assert 10_000 <= p["n_samples"] <= 150_000
        assert 30 - 1e-9 <= p["duration_s"] <= 200 + 1e-9
        assert 20 <= p["encoder_bits"] <= 26
        q = p["count_rad"]
        bristle = max(p["static_pos_nm"], p["static_neg_nm"]) / p["sigma0_nm_rad"]
        if "presliding" in hidden:
            assert 20 * q * 0.999 <= fc / p["sigma0_nm_rad"] <= 300 * q * 1.001
        else:
            assert bristle < q
        two = "backlash" in hidden or "compliant_mode" in hidden
        assert ("two_mass" in p) == two
        if "asymmetric_friction" in truth:
            t = truth["asymmetric_friction"]
            r = max(t.values()) / min(t.values())
            assert 1.2 <= r <= 2.0
        if "position_periodic" in truth:
            t = truth["position_periodic"]
            assert 2 <= p["travel_rad"] / t["period_rad"] <= 50
            assert 0.03 * fc <= t["amplitude_nm"] <= fc
        if "gravity_imbalance" in truth:
            assert p["travel_rad"] >= math.radians(60)
            assert 0.05 * fc <= truth["gravity_imbalance"]["amplitude_nm"] <= 2 * fc
        if "time_periodic" in truth:
            t = truth["time_periodic"]
            assert 0.02 <= t["frequency_hz"] <= 10 and t["frequency_hz"] < p["fs_log_hz"] / 4
            assert t["frequency_hz"] * p["duration_s"] >= 3
            assert 0.03 * fc <= t["amplitude_nm"] <= fc
        if "backlash" in truth:
            b = truth["backlash"]["width_rad"]
            assert 20 * q * 0.999 <= b <= 400 * q * 1.001
            assert 5 <= p["two_mass"]["resonance_hz"] <= 40
        if "compliant_mode" in hidden:
            assert p["two_mass"]["backlash_width_rad"] == 0.0
            assert 3 <= p["two_mass"]["resonance_hz"] <= 15


def test_clean_records_have_no_effect(draws):
    for s, p in draws.items():
        if p["hidden"]:
            continue
        sim = p["_sim"]
        assert sim["a_pp"] == sim["a_g"] == sim["a_t"] == 0.0
        assert not sim["two_mass"] and sim["half_b"] == 0.0
        assert sim["fv_p"] == sim["fv_n"] and sim["fc_p"] == sim["fc_n"]
        assert np.all(sim["fc_fac"] == 1.0) and np.all(sim["fv_fac"] == 1.0)
        assert sim["kappa_ld"] == 0.0 and p["measurement"]["torque_skew_s"] == 0.0
        assert max(sim["fs_p"], sim["fs_n"]) / sim["sigma0"] < p["count_rad"]


# --------------------------------------------------------------- determinism
def test_determinism_and_seed_dependence():
    recs = {}
    for s in (7, 21):
        a = br.make_record(s)
        b = br.make_record(s)
        assert a.hidden == b.hidden == br.plan()[s]
        for f in ("t_s", "torque_nm", "position_rad"):
            assert np.array_equal(getattr(a, f), getattr(b, f))
        assert a.truth == b.truth and a.meta == b.meta
        recs[s] = a
    a, b = recs[7], recs[21]
    assert len(a.t_s) != len(b.t_s) or not np.array_equal(a.torque_nm, b.torque_nm)
    c = br.make_record(7, hidden=())
    assert c.hidden == () and c.truth == {}
    assert not np.array_equal(c.torque_nm, a.torque_nm)


# --------------------------------------------------------------- record format
def test_columns_meta_quantisation_and_csv(tmp_path):
    r = br.make_record(7)
    m = r.meta
    n = len(r.t_s)
    assert r.torque_nm.shape == r.position_rad.shape == (n,)
    assert isinstance(m["fs_log_hz"], float) and isinstance(m["trajectory"], str)
    assert isinstance(m["n_reversals"], int)
    fs = m["fs_log_hz"]
    assert r.t_s[0] == 0.0
    assert np.allclose(np.diff(r.t_s), 1.0 / fs, rtol=1e-9, atol=0)
    counts = r.position_rad / m["count_rad"]
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6
    assert m["counts_per_rev"] == 2 ** m["encoder_bits"]
    assert np.all(np.isfinite(r.torque_nm))
    path = tmp_path / "r.csv"
    r.write_csv(path)
    assert path.read_text().splitlines()[0] == "time_s,torque_nm,position_rad"
    back = np.loadtxt(path, delimiter=",", skiprows=1)
    for j, col in enumerate((r.t_s, r.torque_nm, r.position_rad)):
        assert np.allclose(back[:, j], col, rtol=1e-11, atol=0.0)


# --------------------------------------------------------------- physics
def _plateau_check(seed):
    r = br.make_record(seed, ())
    m = r.meta
    vs = m["stribeck_velocity_rad_s"]
    fc, fs, fv = m["coulomb_nm"], m["static_pos_nm"], m["viscous_nm_s_rad"]
    d = m["stribeck_exponent"]
    lsb = m["measurement"].get("adc_lsb_nm", 0.0)
    n_checked = 0
    for t0, t1, v in m["trajectory_info"]["plateaus"]:
        if abs(v) < 5 * vs or t1 - t0 < 4.0:
            continue
        sel = (r.t_s >= t0 + 0.5 * (t1 - t0)) & (r.t_s <= t1 - 0.2)
        x = r.torque_nm[sel]
        nb = 10
        bs = len(x) // nb
        means = x[: nb * bs].reshape(nb, bs).mean(axis=1)
        se = means.std(ddof=1) / math.sqrt(nb)
        g = fc + (fs - fc) * math.exp(-abs(v / vs) ** d)
        expected = m["offset_nm"] + math.copysign(g, v) + fv * v
        assert abs(x.mean() - expected) <= 4.0 * se + 0.5 * lsb, (seed, v)
        # the check has teeth: a sign error in the viscous or Coulomb term
        # would be far outside the band
        assert min(2 * abs(fv * v), 2 * g) > 4.0 * se + 0.5 * lsb
        n_checked += 1
    assert n_checked >= 2


def _staircase_ok(p, chain):
    vs = p["stribeck_velocity_rad_s"]
    pl = [x for x in p["trajectory_info"].get("plateaus", [])
          if abs(x[2]) >= 5 * vs and x[1] - x[0] >= 4]
    return p["trajectory"] == "staircase" and len(pl) >= 2 and p["measurement"]["logged"] == chain


@pytest.mark.parametrize("chain", ["command", "current"])
def test_clean_staircase_plateau_torque_matches_friction_law(chain):
    seed, _ = _first_seed(lambda p: _staircase_ok(p, chain))
    _plateau_check(seed)


def test_bristle_state_bounded_at_the_chosen_step():
    for hidden in ((), ("presliding",)):
        seed, p = _first_seed(lambda p: p["n_samples"] < 40_000, hidden=hidden)
        sim = br._simulate(p)
        s = p["_sim"]
        h = s["tc"] / s["n_sub"]
        assert h <= 1e-4
        f_s = max(s["fs_p"], s["fs_n"])
        zf = np.abs(sim["z"]) * s["sigma0"]
        assert np.all(np.isfinite(zf)) and zf.max() <= f_s * (1 + 1e-9)
        assert zf.max() > 0.5 * p["coulomb_nm"]  # it did slide
        if not hidden:
            # stiff bristles: while sliding, dz/dt = v - a z relaxes at
            # a = sigma0 |v| / g(v) >= sigma0 |v| / Fs; h * a far above 2
            # means explicit Euler would have diverged at this step
            v = np.diff(sim["load"]) / s["tc"]
            assert h * s["sigma0"] * np.max(np.abs(v)) / f_s > 20.0


def test_backlash_gear_transmits_nothing_inside_dead_zone():
    seeds = [s for s in br.BLIND_SEEDS if br.plan()[s] == ("backlash",)]
    p = min((br._draw(s, ("backlash",)) for s in seeds), key=lambda p: p["n_samples"])
    sim = br._simulate(p)
    s = p["_sim"]
    half_b = s["half_b"]
    assert half_b == 0.5 * p["_truth"]["backlash"]["width_rad"]
    tw, sp = sim["twist"], sim["spring"]
    inside = np.abs(tw) < half_b
    assert np.any(inside) and np.any(~inside)
    assert np.all(sp[inside] == 0.0)
    # outside the gap the gear pushes in the direction of the twist
    assert np.all(sp[tw > half_b] >= 0.0) and np.all(sp[tw < -half_b] <= 0.0)
    assert np.max(np.abs(sp)) > p["coulomb_nm"]
    # logged position is the motor side (twist visible against the load angle)
    r = br.make_record(p["seed"])
    assert "two_mass" in r.meta and r.meta["two_mass"]["stiffness_nm_rad"] == s["k_gear"]
    idx = np.arange(len(r.t_s)) * p["decimation"]
    q = p["count_rad"]
    assert np.allclose(r.position_rad, np.floor(sim["meas"][idx] / q) * q)
    assert np.max(np.abs(sim["meas"] - sim["load"])) > half_b
