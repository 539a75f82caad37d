"""Identify the stage-1 gear-mesh amplitude on paper Fig. 6a alone, and write it into the parameter file.

``schmidt-fil identify-mesh [--params FILE] [--write]`` (issue 9). What it does, repeatably:

1. Runs ``scenarios/paper/fig6a-open-loop-600.yaml`` — RA open loop at 600″/s, reduced
   preload, the duty from the operator's duty–speed map — with the RA stage-1 mesh amplitude A
   (``axes.ra.gear_disturbance.stage1_mesh.amplitude_nm``) set by a scenario override; every other
   number comes from the parameter file.
2. Measures the segment's ``peak_error_tick_pct`` (the firmware's 5 ms QEI-difference rate,
   :mod:`host.rate_metrics`) and finds by bisection the A at which it reaches the paper's 15 %
   ("Without a feedback controller, the peak error reaches up to 15 %", §4, Fig. 6a): the
   bracket [lo, hi] with peak(lo) < 15 % ≤ peak(hi) is halved until hi − lo ≤ ``tol_nm``
   (0.1 N·m); the result is hi rounded to 0.1 N·m. The per-tick peak is quantised (one count per
   tick = 0.38 % at 600″/s), so the bisection finds the edge where the worst tick first reaches
   15 %.
3. With ``--write``, replaces that one leaf of the parameter file (value and source; every
   comment and other line untouched) and reloads the file to check it.

Why only Fig. 6a: the stage-1 mesh is the only gear line whose frequency at 600–1000″/s
(4.5–7.5 Hz) lies where the paper's closed/open ratio (7 % / 15 %) puts the dominant disturbance,
and Fig. 6a is the only figure measured without the controller (so the amplitude does not depend
on the gains). Every other figure is then a prediction (``schmidt-fil validate-paper``). DEC has no
figure: its amplitude stays 0.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from plant.params import DEFAULT_PATH, load_parameters

__all__ = ["IDENT_SCENARIO", "IDENT_KEY", "TARGET_PCT", "Identification", "identify_stage1_mesh",
           "write_amplitude"]

#: The identification scenario (paper Fig. 6a).
IDENT_SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "paper" / "fig6a-open-loop-600.yaml"
#: The parameter identified.
IDENT_KEY = "axes.ra.gear_disturbance.stage1_mesh.amplitude_nm"
#: Paper §4, Fig. 6a: open-loop peak error at high speed, reduced preload [%].
TARGET_PCT = 15.0
#: Segment of the identification scenario and the metric matched.
SEGMENT = "ol600"
METRIC = "peak_error_tick_pct"


@dataclass
class Identification:
    """Result of :func:`identify_stage1_mesh`.

    Attributes
    ----------
    amplitude_nm : float
        Identified amplitude [N·m at the axis, each train].
    peak_pct : float
        ``peak_error_tick_pct`` of the run at ``amplitude_nm``.
    bracket_nm : tuple of float
        Final (lo, hi).
    runs : list of (float, float)
        Every (amplitude, peak %) evaluated, in order.
    """

    amplitude_nm: float
    peak_pct: float
    bracket_nm: tuple
    runs: list = field(default_factory=list)

    def source_text(self, params_path: Path) -> str:
        """The ``source`` written next to the value in the parameter file."""
        return (f"identified by `schmidt-fil identify-mesh` on paper Fig. 6a alone (open loop, 600 arcsec/s, "
                f"reduced preload, peak error {TARGET_PCT:g} % per 5 ms tick; scenario "
                f"scenarios/paper/fig6a-open-loop-600.yaml): A = {self.amplitude_nm:g} N m gives "
                f"peak_error_tick_pct = {self.peak_pct:g} % (bisection bracket {self.bracket_nm[0]:g}-"
                f"{self.bracket_nm[1]:g} N m, {len(self.runs)} runs). Fig. 6a is not used as a prediction.")


def _peak(scenario, amplitude_nm: float, params_path: Path | None) -> float:
    from host.runner import run_scenario

    pc = scenario.plant
    upd = {"overrides": {**pc.overrides, IDENT_KEY: float(amplitude_nm)}}
    if params_path is not None:
        upd["parameter_file"] = str(Path(params_path).resolve())
    sc = scenario.model_copy(update={"plant": pc.model_copy(update=upd)})
    res = run_scenario(sc, None, plots=False)
    seg = next(s for s in res.report["segments"] if s["name"] == SEGMENT)
    return float(seg[METRIC])


def identify_stage1_mesh(params_path: Path | None = None, scenario_path: Path = IDENT_SCENARIO,
                         target_pct: float = TARGET_PCT, tol_nm: float = 0.1, hi0_nm: float = 10.0,
                         max_nm: float = 2000.0, progress=None) -> Identification:
    """Find the stage-1 mesh amplitude at which Fig. 6a's open-loop run peaks at ``target_pct``.

    Parameters
    ----------
    params_path : Path, optional
        Parameter file the runs use (default the packaged one).
    scenario_path : Path
        Identification scenario (default Fig. 6a's).
    target_pct : float
        Paper figure [%] (15, §4).
    tol_nm : float
        Final bracket width [N·m].
    hi0_nm, max_nm : float
        First upper guess (doubled until the target is reached) and the give-up limit [N·m].
    progress : callable(amplitude_nm, peak_pct), optional
        Called after every run.

    Returns
    -------
    Identification

    Raises
    ------
    ValueError
        The run already exceeds the target without the line (nothing to identify), or the target
        is not reached below ``max_nm``.
    """
    from host.scenario import load_scenario

    sc = load_scenario(scenario_path)
    runs: list = []

    def f(a):
        p = _peak(sc, a, params_path)
        runs.append((a, p))
        if progress:
            progress(a, p)
        return p

    p0 = f(0.0)
    if p0 >= target_pct:
        raise ValueError(f"{scenario_path}: peak {p0:g} % >= {target_pct:g} % already without the mesh line")
    lo, hi = 0.0, hi0_nm
    p_hi = f(hi)
    while p_hi < target_pct:
        lo, hi = hi, 2.0 * hi
        if hi > max_nm:
            raise ValueError(f"{scenario_path}: peak stays below {target_pct:g} % up to {max_nm:g} N m")
        p_hi = f(hi)
    while hi - lo > tol_nm:
        mid = 0.5 * (lo + hi)
        pm = f(mid)
        if pm >= target_pct:
            hi, p_hi = mid, pm
        else:
            lo = mid
    a = round(hi, 1)
    pa = p_hi if a == hi else f(a)
    if pa < target_pct:  # rounding moved below the edge: take the next 0.1 up
        a = round(a + 0.1, 1)
        pa = f(a)
    return Identification(amplitude_nm=a, peak_pct=pa, bracket_nm=(round(lo, 3), round(hi, 3)), runs=runs)


def write_amplitude(params_path: Path, ident: Identification) -> None:
    """Replace the ``amplitude_nm`` leaf of ``axes.ra.gear_disturbance.stage1_mesh`` in place.

    Only that one line changes (a flow-style leaf ``{value, unit, source}``); the file is then
    reloaded and the value checked.

    Raises
    ------
    ValueError
        The leaf is not found as one line under ``axes: ra: gear_disturbance: stage1_mesh:``, or the
        reloaded file does not hold the value.
    """
    path = Path(params_path)
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    want = ["axes", "ra", "gear_disturbance", "stage1_mesh", "amplitude_nm"]
    stack: list[tuple[int, str]] = []
    target = None
    for i, line in enumerate(lines):
        m = re.match(r"^(\s*)([A-Za-z0-9_]+):", line)
        if not m or line.lstrip().startswith("#"):
            continue
        ind = len(m.group(1))
        while stack and stack[-1][0] >= ind:
            stack.pop()
        stack.append((ind, m.group(2)))
        if [k for _, k in stack] == want:
            target = (i, m.group(1))
            break
    if target is None or "{" not in lines[target[0]]:
        raise ValueError(f"{path}: no one-line leaf {'.'.join(want)} to write")
    i, indent = target
    unit = "N m at the axis (each train)"
    lines[i] = f'{indent}amplitude_nm: {{value: {ident.amplitude_nm!r}, unit: {unit}, source: "{ident.source_text(path)}"}}\n'
    path.write_text("".join(lines), encoding="utf-8")
    got = load_parameters(path).axes["ra"].gear_disturbance["stage1_mesh"]["amplitude_nm"]
    if got != ident.amplitude_nm:
        raise ValueError(f"{path}: wrote {ident.amplitude_nm} but read back {got}")


def default_params_path() -> Path:
    """The packaged parameter file (``plant/parameters.yaml``)."""
    return DEFAULT_PATH
