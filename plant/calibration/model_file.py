"""Write a calibrated model as a plant parameter file (the format of ``plant/parameters.yaml``).

The calibrated axis (default ``ra``) of the shipped parameter file is replaced:

* ``inertia_kg_m2`` ← fitted inertia (linear records: mass in kg, see below);
* ``friction.<active set>``: ``sigma2_nm_s_rad`` ← viscous, ``tc_nm`` ← Coulomb, ``ts_nm`` ← static
  level (= Coulomb when no Stribeck term was fitted), ``omega_s_rad_s`` ← Stribeck velocity (kept
  when none was fitted: with ``ts = tc`` it has no effect);
* ``effects`` ← the accepted effects (``asymmetric_friction`` and ``presliding`` are mapped onto
  the LuGre parameters by :func:`plant.friction.lugre_from_parameters`);
* each changed leaf's ``source`` says ``calibrated: <record> …``.

The fitted **offset** has no place in the plant (it has no constant-load term); it is recorded
in the ``source`` of ``tc_nm``. Linear records (EMPS) are written in their own units (kg, N, m
taking the place of kg·m², N·m, rad): the file then describes an EMPS-like drive on that axis,
which is what a scenario loading it emulates.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from plant.calibration.loop import LoopResult


def write_model_file(result: LoopResult, path: str | Path, record_name: str, axis: str = "ra",
                     backlash_gap: float | None = None) -> Path:
    """Write the calibrated plant parameter file; returns its path.

    ``backlash_gap``: the gap [rad or m] from :func:`plant.calibration.loop.backlash_gap`; the
    backlash effect then carries the gap instead of the fitted width (the plant's compliant
    gear adds its own wind-up to the gap, so writing the width would count the wind-up twice).

    Raises
    ------
    plant.params.ParameterError
        ``axis`` is not an axis of the parameter file.
    """
    from plant.params import ParameterError, dump_parameters, load_parameters

    params = load_parameters()
    if axis not in params.axes:
        raise ParameterError(f"calibrate --axis {axis!r}: valid axes are {sorted(params.axes)}")
    fit = result.final
    names = fit.params()
    ax = params.axes[axis]
    fr = ax.friction
    active = fr.preload
    s = fr.active
    if "viscous" in names:
        visc, coul = names["viscous"], names["coulomb"]
    else:  # asymmetric: the symmetric set gets the mean (the effect overrides per direction)
        visc = 0.5 * (names["viscous_pos"] + names["viscous_neg"])
        coul = 0.5 * (names["coulomb_pos"] + names["coulomb_neg"])
    ts = coul + names["stribeck"] if "stribeck" in names else coul
    vs = fit.spec.stribeck_vs if fit.spec.stribeck_vs is not None else s.omega_s_rad_s
    new_set = dataclasses.replace(s, sigma2_nm_s_rad=max(visc, 0.0), tc_nm=max(coul, 0.0), ts_nm=max(ts, 0.0), omega_s_rad_s=vs)
    fr2 = dataclasses.replace(fr, **{active: new_set})
    effects = tuple(e.to_spec() for e in result.effects())
    if backlash_gap is not None:
        effects = tuple({**e, "width_rad": backlash_gap} if e["kind"] == "backlash" else e for e in effects)
    ax2 = dataclasses.replace(ax, inertia_kg_m2=max(names["inertia"], 1e-12), friction=fr2, effects=effects)
    axes = dict(params.axes)
    axes[axis] = ax2
    params2 = dataclasses.replace(params, axes=axes)
    tree = params2.tree
    tag = f"calibrated: schmidt-fil calibrate on {record_name}"
    node = tree["axes"][axis]
    unit_note = " (linear record: units are kg, N, m in place of kg m^2, N m, rad)" if result.linear else ""
    node["inertia_kg_m2"]["source"] = f"{tag}{unit_note}"
    off = names.get("offset")
    off_txt = f"; fitted offset {off:.4g} (not representable in the plant)" if off is not None else ""
    for key in ("sigma2_nm_s_rad", "tc_nm", "ts_nm", "omega_s_rad_s"):
        node["friction"][active][key]["source"] = tag + (off_txt if key == "tc_nm" else "") + (
            "" if key != "ts_nm" or "stribeck" in names else " (no Stribeck term: data did not excite it; ts = tc)"
        )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    dump_parameters(params2, path)
    return path
