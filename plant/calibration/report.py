"""Run the calibration on a record and write ``report.json``, ``report.md`` and PNG plots.

:func:`calibrate` is what ``schmidt-fil calibrate`` calls. ``report.json`` keys (issue 3):
``baseline {params, rms, relative_error_pct}``, ``effects`` (ordered list of ``{kind, params,
rms_after, variance_explained_pct, evidence, competitors}``; a competitor that passed the rule too
carries the winner's head-to-head ``head_to_head_gain_pct``, ``head_to_head_z`` and ``separated``), ``final {params, rms, relative_error_pct}``,
``validation {rms_before, rms_after, rms_after_library_only}`` (with a held-out record), ``unexplained`` (list of
``{domain, frequency, share_pct}``), ``model_file``. Extra keys: ``units``, ``uncertainty``,
``significance`` (the rule), ``stribeck`` (the decision), ``rejected`` (candidates turned down:
``reason``, the first rule that refused it, and ``also``, the other rules of the record's geometry
that refuse it too, and ``rules``, the names of those geometry rules (``loop.GEOMETRY_RULES``;
``loop._static_refusals``); a rejected line also ``line {frequency, unit}``, its refined frequency, and
``same_line_as {frequency, bins_apart}`` where another candidate of the step lies within half a bin of it,
``loop._lines_described``), ``undecided`` (effects that predict better but that the record cannot decide: reversal
effects on too few reversals, with ``min_reversals``, the fewest a sign test (the rank test) can pass on at the run's level,
``unit_test`` (the reversals' own t-test was made too, session 61)
and ``advised_reversals``, what the rank test needs, ``loop.rank_batches_needed``; and terms the phase guard refuses on a
periodic motion; ``reason``, ``note``), ``closed_loop`` (EMPS records), ``log``.

Parameter names carry units; for linear records (``--linear``, EMPS) they follow the record:
``mass_kg``, ``viscous_n_s_m``, ``coulomb_n``, ``period_m``, ``amplitude_n`` …
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from plant.calibration import residuals as res
from plant.calibration.fit import FitResult, prepare
from plant.calibration.io import Record, load_record
from plant.calibration.two_mass import GAP_TWO_MASS, two_mass_gap
from plant.calibration.loop import (GAP_FORMULA, LoopConfig, LoopResult, backlash_gap, check_stiffness, friction_levels,
                                     geared_gap, run_loop)

__all__ = ["calibrate", "param_names", "effect_params"]

_ROT = {
    "inertia": "inertia_kg_m2", "viscous": "viscous_nm_s_rad", "coulomb": "coulomb_nm", "offset": "offset_nm",
    "viscous_pos": "viscous_pos_nm_s_rad", "viscous_neg": "viscous_neg_nm_s_rad",
    "coulomb_pos": "coulomb_pos_nm", "coulomb_neg": "coulomb_neg_nm",
    "stribeck": "static_minus_coulomb_nm", "presliding_damping": "sigma1_nm_s_rad",
}
_LIN = {
    "inertia": "mass_kg", "viscous": "viscous_n_s_m", "coulomb": "coulomb_n", "offset": "offset_n",
    "viscous_pos": "viscous_pos_n_s_m", "viscous_neg": "viscous_neg_n_s_m",
    "coulomb_pos": "coulomb_pos_n", "coulomb_neg": "coulomb_neg_n",
    "stribeck": "static_minus_coulomb_n", "presliding_damping": "sigma1_n_s_m",
}
_EFF_LIN = {
    "period_rad": "period_m", "amplitude_nm": "amplitude_n", "viscous_pos_nm_s_rad": "viscous_pos_n_s_m",
    "viscous_neg_nm_s_rad": "viscous_neg_n_s_m", "coulomb_pos_nm": "coulomb_pos_n", "coulomb_neg_nm": "coulomb_neg_n",
    "sigma0_nm_rad": "sigma0_n_m", "sigma1_nm_s_rad": "sigma1_n_s_m", "width_rad": "width_m",
}


def param_names(fit: FitResult, linear: bool) -> tuple[dict[str, float], dict[str, float]]:
    """Fitted parameters and their (autocorrelation-inflated) standard deviations with unit names.

    Sine/cosine pairs of periodic terms are left to the effects list; nonlinear
    hyper-parameters (Stribeck velocity, periods, …) are included without a standard deviation.
    """
    table = _LIN if linear else _ROT
    vals: dict[str, float] = {}
    sds: dict[str, float] = {}
    for n, c, s in zip(fit.names, fit.coef, fit.std_eff):
        if n.endswith("_sin") or n.endswith("_cos"):
            continue
        key = table.get(n, n)
        vals[key] = float(c)
        sds[key] = float(s)
    if fit.spec.stribeck_vs is not None:
        vals["stribeck_velocity_m_s" if linear else "stribeck_velocity_rad_s"] = float(fit.spec.stribeck_vs)
    return vals, sds


def effect_params(spec: dict[str, Any], linear: bool) -> dict[str, Any]:
    """Effect parameters for the report (linear records: ``period_m``, ``amplitude_n`` …)."""
    out = {k: v for k, v in spec.items() if k != "kind"}
    if linear:
        out = {_EFF_LIN.get(k, k): v for k, v in out.items()}
    return out


SIGNIFICANCE_TEXT = (
    "A candidate effect is added when it predicts data the fit did not see: the record is cut into {k} contiguous "
    "time blocks, each predicted by the model fitted on the others (held-out samples that only the candidate's fold "
    "extrapolates to, leverage above that of every training row, count in neither loss); the reduction of the "
    "squared prediction error, averaged over 40 contiguous batches, must be positive overall and significant by Wilcoxon's signed-rank test "
    "(Diebold-Mariano 1995) at a family-wise error of {alpha:g} over all candidate tests of the run (Bonferroni: "
    "z >= about 3.6 for 12 candidates x 5 steps). Parameters are fitted inside physical bounds. With --validate the "
    "held-out rms must fall too. Of the candidates that pass, the largest predictive gain wins; the others are "
    "listed as its competitors. On a periodic motion (K harmonics of one fundamental explain >= 95 % of the velocity, "
    "K the smallest from 3 to 15 that does: 3 for a sinusoid, up to 9 for a back-and-forth sweep) "
    "gravity, position- and time-periodic candidates must also predict with those harmonics in both models, and a time "
    "line within one frequency bin (1/T) of one of them is refused (the phase guard). Transitions under 10 position "
    "quanta are not resolved and not added, nor are time or position lines whose amplitude, as the inertial torque "
    "of a motion (A/(J w^2)), moves the axis by under 10 quanta, unless a position line lies at a declared period of "
    "the drive (--drive-periods). A pre-sliding or backlash candidate must also predict with the Stribeck term in both "
    "models, its velocity re-chosen on the current model (where the model lacks the term, or where the re-chosen one "
    "fits it better): low-speed friction at the reversals is not a transition. Out-of-library "
    "descriptions (friction drift, delay) compete as well and win only when significantly better than the best "
    "library candidate; a winner is reported in 'unexplained', never written to the plant file."
)


LOST_MOTION_TEXT = (
    "the width is the motion lost at a reversal as the logged position sees it: in a compliant drive the gap plus "
    "half the gear's wind-up, width ≈ gap + (Fc + Ts)/(2k); give the drive's stiffness (--gear-stiffness) for the "
    "gap (docs/calibration.md, 'Session 15', 'Session 32')"
)

GEARED_GAP_TEXT = (
    "the width is the gap itself as the massless description fits it: with the drive's stiffness declared "
    "(--gear-stiffness) and that spring's mode above the fit's band, the backlash is fitted as a gap inside the spring, "
    "whose wind-up is modelled (docs/calibration.md, 'Session 35'); where a two-mass refit with the load's inertia "
    "predicts held-out blocks better, the gap below is that refit's ('Session 37')"
)
GAP_FITTED_IN_SPRING = "fitted by the loop as a gap inside the declared gear spring (its mode above the fit's band)"


def _fit_block(fit: FitResult, linear: bool) -> dict[str, Any]:
    vals, _ = param_names(fit, linear)
    return {"params": vals, "rms": fit.rms, "relative_error_pct": fit.relative_error_pct}


def _plots(out: Path, prep, result: LoopResult, prep_val=None) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    units = prep.record.units
    base, fin = result.baseline.residual, result.final.residual
    # residual vs velocity
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(prep.dq_dec, base, ".", ms=2, alpha=0.3, label="baseline residual")
    vp = res.velocity_profile(prep.dq_dec, base)
    ax.plot(vp["centers"], vp["mean"], "k-o", ms=3, label="binned mean (baseline)")
    vf = res.velocity_profile(prep.dq_dec, fin)
    ax.plot(vf["centers"], vf["mean"], "r-o", ms=3, label="binned mean (final)")
    ax.set_xlabel(f"velocity [{units['velocity']}]"), ax.set_ylabel(f"residual [{units['torque']}]"), ax.legend(), ax.grid(True)
    fig.tight_layout(), fig.savefig(out / "residual_vs_velocity.png", dpi=110), plt.close(fig)
    files.append("residual_vs_velocity.png")
    # position and time spectra
    fig, axs = plt.subplots(2, 1, figsize=(7, 6))
    for r, lab, col in ((base, "baseline", "C0"), (fin, "final", "C3")):
        ps = res.position_spectrum(prep.q_dec, prep.dq_dec, r)
        axs[0].plot(ps["freq"], 100 * ps["share"], col, lw=0.8, label=lab)
        ts = res.time_spectrum(prep.t_dec, r)
        axs[1].plot(ts["freq"], 100 * ts["share"], col, lw=0.8, label=lab)
    axs[0].set_xlabel(f"cycles per {units['position']}"), axs[0].set_ylabel("share of residual var. [%]")
    axs[1].set_xlabel("frequency [Hz]"), axs[1].set_ylabel("share of residual var. [%]")
    for a in axs:
        a.legend(), a.grid(True)
    fig.tight_layout(), fig.savefig(out / "residual_spectra.png", dpi=110), plt.close(fig)
    files.append("residual_spectra.png")
    # residual vs position (moving samples)
    mov = res.moving_mask(prep.dq_dec)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(prep.q_dec[mov], base[mov], ".", ms=2, alpha=0.4, label="baseline")
    ax.plot(prep.q_dec[mov], fin[mov], ".", ms=2, alpha=0.4, label="final")
    ax.set_xlabel(f"position [{units['position']}]"), ax.set_ylabel(f"residual [{units['torque']}]"), ax.legend(), ax.grid(True)
    fig.tight_layout(), fig.savefig(out / "residual_vs_position.png", dpi=110), plt.close(fig)
    files.append("residual_vs_position.png")
    # reversal profile
    fig, ax = plt.subplots(figsize=(7, 4))
    for r, lab in ((base, "baseline"), (fin, "final")):
        rv = res.reversal_profile(prep.t_dec, prep.dq_dec, r)
        ax.plot(rv["lag_s"], rv["mean"], label=f"{lab} ({rv['n_reversals']} reversals)")
    ax.set_xlabel("time from velocity reversal [s]"), ax.set_ylabel(f"mean signed residual [{units['torque']}]"), ax.legend(), ax.grid(True)
    fig.tight_layout(), fig.savefig(out / "residual_at_reversals.png", dpi=110), plt.close(fig)
    files.append("residual_at_reversals.png")
    # before / after in time
    n_rows = 2 if prep_val is not None else 1
    fig, axs = plt.subplots(n_rows, 1, figsize=(9, 3.2 * n_rows), squeeze=False)
    a = axs[0, 0]
    a.plot(prep.t_dec, prep.y_dec, "k", lw=0.8, label="measured")
    a.plot(prep.t_dec, base, "C0", lw=0.6, label=f"residual baseline (rms {result.baseline.rms:.3g})")
    a.plot(prep.t_dec, fin, "C3", lw=0.6, label=f"residual final (rms {result.final.rms:.3g})")
    a.set_title(f"training: {prep.record.name}"), a.set_xlabel("time [s]"), a.set_ylabel(units["torque"]), a.legend(fontsize=8), a.grid(True)
    if prep_val is not None:
        a = axs[1, 0]
        a.plot(prep_val.t_dec, prep_val.y_dec, "k", lw=0.8, label="measured")
        a.plot(prep_val.t_dec, result.val_baseline[1], "C0", lw=0.6, label=f"residual baseline (rms {result.val_rms_before:.3g})")
        a.plot(prep_val.t_dec, result.val_final[1], "C3", lw=0.6, label=f"residual final (rms {result.val_rms_after:.3g})")
        a.set_title(f"held-out: {prep_val.record.name}"), a.set_xlabel("time [s]"), a.set_ylabel(units["torque"]), a.legend(fontsize=8), a.grid(True)
    fig.tight_layout(), fig.savefig(out / "before_after.png", dpi=110), plt.close(fig)
    files.append("before_after.png")
    return files


def _closed_loop(record: Record, result: LoopResult) -> dict[str, Any] | None:
    if record.extra.get("format") != "emps":
        return None
    from plant.calibration.emps_closed_loop import force_error_pct, model_from_fit, simulate_closed_loop

    eff = result.effects()
    out = {
        "record": record.name,
        "reference_model_pct_documented": 5.85,
        "baseline_pct": force_error_pct(record, simulate_closed_loop(record, model_from_fit(result.baseline))),
        "final_effects_off_pct": None,
        "final_with_effects_pct": force_error_pct(record, simulate_closed_loop(record, model_from_fit(result.final, eff))),
    }
    out["final_effects_off_pct"] = force_error_pct(
        record, simulate_closed_loop(record, model_from_fit(result.final, eff, with_effects=False))
    )
    return out


def _not_told_apart(effect: dict[str, Any], named: set[str]) -> str:
    """`` (not told apart from X by this record)`` where a library competitor that passed the rule too is
    not beaten head to head at the run's level (``competitors[i]["separated"]``, session 52) and is not
    itself among the ``named`` kinds (then both are in the model, not alternatives), else ``""``: the
    conclusion then says that the name is the larger gain's, not a decision of the record."""
    close = [c["kind"] for c in effect.get("competitors", []) if c.get("separated") is False and c["kind"] not in named]
    return f" (not told apart from {' or '.join(close)} by this record)" if close else ""


def calibrate(
    record_path: str | Path,
    out_dir: str | Path,
    validate_path: str | Path | None = None,
    columns: dict[str, str] | None = None,
    linear: bool = False,
    config: LoopConfig | None = None,
    plots: bool = True,
    closed_loop: bool = True,
    axis: str = "ra",
    gear_stiffness: float | None = None,
) -> dict[str, Any]:
    """Calibrate: load, fit the baseline, run the effect loop, write the report and the model file.

    Parameters
    ----------
    record_path : path
        Training record (``.mat`` EMPS or CSV).
    out_dir : path
        Output directory (created).
    validate_path : path, optional
        Held-out record.
    columns, linear
        CSV column mapping and linear units (see :mod:`plant.calibration.io`).
    config : LoopConfig, optional
    plots, closed_loop : bool
        Write the PNGs; run the EMPS closed-loop check (EMPS records only).
    axis : str
        Axis of the plant parameter file that receives the calibrated model.
    gear_stiffness : float, optional
        Stiffness of the drive between the logged position and the load [N·m/rad; N/m for linear
        records], from the drive's design. A pre-sliding or backlash effect must then also
        predict better than the current model with this spring in it
        (:func:`plant.calibration.loop._beats_gear_spring`). The fitted backlash width is the motion lost at a
        reversal (the gap plus half the gear's wind-up); with the stiffness the report also gives
        the gap — refitted after the loop with the gap inside the declared spring
        (:func:`plant.calibration.loop.geared_gap`, session 32), or, where the spring's swing is
        under 10 position quanta, the width minus half the wind-up
        (:func:`plant.calibration.loop.backlash_gap`) — and says which; the plant file, whose gear
        adds its own wind-up, receives the gap instead of the width.

    Returns
    -------
    dict
        The content of ``report.json``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = config or LoopConfig()
    if gear_stiffness is not None:
        check_stiffness(gear_stiffness, "--gear-stiffness")   # before anything runs or is written
        cfg = dataclasses.replace(cfg, gear_stiffness=gear_stiffness)
    rec = load_record(record_path, columns=columns, linear=linear, axis=axis)
    linear = rec.linear
    prep = prepare(rec)
    prep_val = None
    rec_val = None
    if validate_path is not None:
        rec_val = load_record(validate_path, columns=columns, linear=linear, axis=axis)
        prep_val = prepare(rec_val)
    result = run_loop(prep, prep_val, cfg, linear=linear)
    from plant.calibration.model_file import write_model_file

    gap = None
    gap_how: dict[str, Any] = {}
    if gear_stiffness is not None and result.final.spec.backlash_width is not None:
        if result.final.spec.geared:
            # named as a gap inside the declared (quasi-static) spring: the width is the gap (session 35)
            gap, gap_how = result.final.spec.backlash_width, {"method": GAP_FITTED_IN_SPRING}
        else:
            gap, gap_how = geared_gap(prep, result.final, gear_stiffness)
        if gap is None:   # the spring's swing is not resolved: subtract half of it from the lost motion
            fc, ts = friction_levels(result.final)
            gap = backlash_gap(result.final.spec.backlash_width, fc, ts, gear_stiffness)
        # the load's inertia and friction levels: refit the gap with a two-mass drive; used where it
        # predicts held-out blocks better than the loop's massless model (sessions 36-37)
        gap0 = gap if gap > 0 else result.final.spec.backlash_width
        if gap0 is not None and gap0 > 0:
            tm_gap, tm_info = two_mass_gap(prep, result.final, gear_stiffness, gap0, cfg.k_folds)
        else:   # nothing to search around: keep the massless gap (never reached on the benchmark)
            tm_gap, tm_info = None, {"why": "neither the massless gap nor the fitted width is positive"}
        tm_info["massless_gap"] = gap
        tm_info["massless_method"] = gap_how.get("method", GAP_FORMULA)
        gap_how = {"method": GAP_TWO_MASS if tm_gap is not None else tm_info["massless_method"], "two_mass": tm_info}
        if tm_gap is not None:
            gap = tm_gap
    model_path = write_model_file(result, out / "calibrated_parameters.yaml", rec.name, axis=axis,
                                  backlash_gap=gap)
    effects = []
    for acc, eff in zip(result.accepted, result.effects()):
        extra: dict[str, Any] = {}
        if acc.kind == "backlash":
            extra["width_meaning"] = GEARED_GAP_TEXT if result.final.spec.geared else LOST_MOTION_TEXT
            if gap is not None:
                extra["gap_m" if linear else "gap_rad"] = gap
                extra["gear_stiffness"] = gear_stiffness
                extra["gap_method"] = gap_how.get("method", GAP_FORMULA)
                if "two_mass" in gap_how:
                    extra["two_mass"] = gap_how["two_mass"]
        effects.append(
            {
                "kind": acc.kind,
                "params": effect_params(eff.to_spec(), linear),
                "rms_after": acc.rms_after,
                "variance_explained_pct": acc.variance_explained_pct,
                "evidence": acc.evidence,
                "delta_bic_eff": acc.delta_bic,
                "cv_gain_pct": acc.cv_gain_pct,
                "cv_z": acc.cv_z,
                "competitors": acc.competitors,
                **({"validation_rms_after": acc.val_rms_after} if acc.val_rms_after is not None else {}),
                **extra,
            }
        )
    _, base_sd = param_names(result.baseline, linear)
    _, fin_sd = param_names(result.final, linear)
    report: dict[str, Any] = {
        "record": str(record_path),
        "units": rec.units,
        "baseline": _fit_block(result.baseline, linear),
        "effects": effects,
        "final": _fit_block(result.final, linear),
        "unexplained": result.unexplained,
        "model_file": str(model_path),
        "uncertainty": {
            "baseline_std": base_sd,
            "final_std": fin_sd,
            "note": "1-sigma from sigma^2 (A^T A)^-1, inflated by sqrt(n/n_eff) for AR(1)-correlated residuals; still optimistic",
        },
        "significance": SIGNIFICANCE_TEXT.format(k=cfg.k_folds, alpha=cfg.family_alpha),
        "stribeck": {k: (float(v) if isinstance(v, (np.floating, float)) else v) for k, v in result.stribeck.items()},
        "rejected": result.rejected,
        "undecided": result.undecided,
        "drive_periods": list(cfg.drive_periods),
        "gear_stiffness": cfg.gear_stiffness,
        "conclusion": (
            f"{len(effects)} effect(s) added: " + ", ".join(e["kind"] + _not_told_apart(e, {x["kind"] for x in effects}) for e in effects)
            if effects else "no significant improvement: no effect added"
        ),
        "preprocessing": {
            "butterworth_order": 4, "cutoff_hz": prep.cutoff_hz, "decimation": prep.decim,
            "n_samples_fit": int(prep.y_dec.size), "n_eff_baseline": result.baseline.n_eff,
            # stretches where the axis sticks and slips at one speed, left out of the fit (session 44)
            "hunting_s": [[float(a), float(b)] for a, b in prep.hunting],
        },
        "log": result.log,
    }
    if prep_val is not None:
        report["validation"] = {"record": str(validate_path), "rms_before": result.val_rms_before, "rms_after": result.val_rms_after,
                                "rms_after_library_only": result.val_rms_after_library}
    if closed_loop:
        cl = _closed_loop(rec, result)
        if cl is not None:
            if rec_val is not None and rec_val.extra.get("format") == "emps":
                # record-specific phases refitted on the held-out record (as in the validation)
                import dataclasses as _dc

                from plant.calibration.fit import predict

                _, _, coef_v = predict(prep_val, result.final, return_coef=True)
                res_v = _dc.replace(result, final=_dc.replace(result.final, coef=coef_v))
                cl["validation"] = _closed_loop(rec_val, res_v)
            report["closed_loop"] = cl
    if plots:
        report["plots"] = _plots(out, prep, result, prep_val)
    (out / "report.json").write_text(json.dumps(_jsonable(report), indent=2, allow_nan=True))
    (out / "report.md").write_text(_markdown(report))
    return report


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _fmt(v: Any) -> str:
    return f"{v:.5g}" if isinstance(v, (float, int)) and not isinstance(v, bool) else str(v)


def _line_name(x: dict[str, Any]) -> str:
    """A candidate's kind, with its refined line (``line``) for a periodic one."""
    return x["kind"] + (f" at {x['line']['frequency']:.6g} {x['line']['unit']}" if "line" in x else "")


def _rejected_name(x: dict[str, Any]) -> str:
    """A rejected candidate's kind, with its refined line for a periodic one and, where several
    spectrum peaks were refined onto one line, which (session 56)."""
    name = _line_name(x)
    if "same_line_as" in x:
        s = x["same_line_as"]
        name += (f" (the same line as the candidate at {s['frequency']:.6g} {x['line']['unit']}, {s['bins_apart']:.2f} bins "
                 "apart: another spectrum peak refined onto it; each peak is a test of its own in the significance level)")
    return name


def _markdown(r: dict[str, Any]) -> str:
    u = r["units"]
    L = [f"# Calibration report: `{r['record']}`", ""]
    L += [f"**Conclusion:** {r['conclusion']}.", ""]
    L += ["## Baseline", "", "| parameter | value | ±1σ (eff.) |", "|---|---|---|"]
    for k, v in r["baseline"]["params"].items():
        L.append(f"| {k} | {_fmt(v)} | {_fmt(r['uncertainty']['baseline_std'].get(k, ''))} |")
    L += ["", f"rms {r['baseline']['rms']:.4g} {u['torque']}, relative error {r['baseline']['relative_error_pct']:.3f} % "
          "(‖y−ŷ‖/‖y‖ on the decimated samples, the EMPS benchmark's definition).", ""]
    L += [f"Stribeck term: {'included' if r['stribeck'].get('included') else 'not included'} — {r['stribeck'].get('reason', '')}.", ""]
    hunting = r["preprocessing"].get("hunting_s") or []
    if hunting:
        spans = ", ".join(f"{a:.1f}–{b:.1f} s" for a, b in hunting)
        L += [f"Hunting: the axis sticks and slips at one commanded speed on {spans} "
              f"({sum(b - a for a, b in hunting):.1f} s); these samples are left out of the fit like rests "
              "(docs/calibration.md, \"Session 44\").", ""]
    L += ["## Effects added (in order)", ""]
    if not r["effects"]:
        L += ["None: no candidate passed the significance rule.", ""]
    for i, e in enumerate(r["effects"], 1):
        ps = ", ".join(f"{k} = {_fmt(v)}" for k, v in e["params"].items())
        L += [f"{i}. **{e['kind']}** ({ps}); rms after {e['rms_after']:.4g}, explains {e['variance_explained_pct']:.1f} % "
              f"of the residual variance. {e['evidence']}"]
        if "width_meaning" in e:
            gk = "gap_m" if "gap_m" in e else "gap_rad"
            L += [f"   Note: {e['width_meaning']}."
                  + (f" With the gear stiffness {_fmt(e['gear_stiffness'])}: **{gk} = {_fmt(e[gk])}** ("
                     f"{e.get('gap_method', GAP_FORMULA)}; written to the plant file)." if gk in e else "")]
            tm = e.get("two_mass")
            if tm is not None and "rss" in tm:
                L += [f"   Two-mass refit (load share {tm['load_share']:.2f} and gear damping ratio {tm['damping_ratio']:.2f}, "
                      f"both fixed; the load's Coulomb and viscous levels ×{tm.get('coulomb_scale', 1.0):.3g} and "
                      f"×{tm.get('viscous_scale', 1.0):.3g} the massless fit's, refitted with the gap): gap {_fmt(tm['gap'])}, "
                      f"held-out gain over the massless model "
                      f"{tm['cv_gain_pct']:.2f} % (z = {tm['cv_z']:.1f}); massless gap {_fmt(tm['massless_gap'])} "
                      f"({tm['massless_method']}). " + ("Used." if "why" not in tm else f"Not used: {tm['why']}.")]
            elif tm is not None:
                L += [f"   Two-mass refit not possible: {tm.get('why', '')}."]
    L += ["", "## Final model", "", "| parameter | value | ±1σ (eff.) |", "|---|---|---|"]
    for k, v in r["final"]["params"].items():
        L.append(f"| {k} | {_fmt(v)} | {_fmt(r['uncertainty']['final_std'].get(k, ''))} |")
    L += ["", f"rms {r['final']['rms']:.4g} {u['torque']}, relative error {r['final']['relative_error_pct']:.3f} %.", ""]
    if "validation" in r:
        v = r["validation"]
        L += ["## Held-out record", "", f"`{v['record']}`: rms {v['rms_before']:.4g} → {v['rms_after']:.4g} {u['torque']} "
              f"({100 * (v['rms_before'] - v['rms_after']) / v['rms_before']:.1f} % lower)."]
        lib = v.get("rms_after_library_only")
        if lib is not None and lib != v["rms_after"]:
            L += ["", f"With the library effects alone (what the calibrated plant file carries; the out-of-library "
                  f"descriptions of the machine, such as a torque–motion delay, dropped): {lib:.4g} {u['torque']} "
                  f"({100 * (v['rms_before'] - lib) / v['rms_before']:.1f} % lower)."]
        L += [""]
    if "closed_loop" in r:
        c = r["closed_loop"]
        L += ["## Closed loop (EMPS controller, simulated)", "",
              "Force error 100·‖F − F_sim‖/‖F‖ (documented for the reference model: 5.85 %):", "",
              "| record | baseline (4 parameters) | final, additive/backlash/presliding off | final with effects |", "|---|---|---|---|"]
        for cc in (c, c.get("validation")):
            if cc:
                L.append(f"| {cc['record']} | {cc['baseline_pct']:.2f} % | {cc['final_effects_off_pct']:.2f} % | {cc['final_with_effects_pct']:.2f} % |")
        L.append("")
    L += ["## Unexplained structure", ""]
    if not r["unexplained"]:
        L += ["None above the reporting threshold.", ""]
    for x in r["unexplained"]:
        where = f"{x['frequency']:.4g} {x.get('unit', '')}" if x.get("frequency") is not None else (x.get("kind") or "broadband")
        L.append(f"- {x['domain']}: {where}, {x['share_pct']:.1f} % of the residual variance"
                 + (f" — {x['note']}" if x.get("note") else ""))
    if r.get("undecided"):
        L += ["", "## Not decided by this record", ""]
        L += [f"- {_line_name(x)}: {x['note']}." for x in r["undecided"]]
    L += ["", "## Significance rule", "", r["significance"]]
    if r.get("drive_periods"):
        L += ["", "Declared periods of the drive (--drive-periods; exempt from the line-resolution limit): "
              + ", ".join(f"{p:.6g}" for p in r["drive_periods"]) + "."]
    if r.get("gear_stiffness") is not None:
        L += ["", f"Declared gear stiffness (--gear-stiffness): {r['gear_stiffness']:.6g}; a pre-sliding or backlash must also "
              "predict better than the current model with this spring in it (docs/calibration.md, 'Session 20'); where the "
              "spring's lowest possible mode, sqrt(K/J)/pi, lies above the fit's band, the backlash candidate is a gap "
              "inside the spring, its width the gap ('Session 35')."]
    L += ["", "## Candidates rejected", ""]
    for x in r["rejected"]:
        L.append(f"- step {x['step']}: {_rejected_name(x)} — {x['reason']}"
                 + "".join(f"; also: {a}" for a in x.get("also", [])))
    L += ["", "## Uncertainty caveat", "", r["uncertainty"]["note"] + ".", ""]
    L += [f"Calibrated plant parameter file: `{r['model_file']}`.", ""]
    if r.get("plots"):
        L += ["## Plots", ""] + [f"![{p}]({p})" for p in r["plots"]] + [""]
    return "\n".join(L)
