"""Session 20 patch (probe): pre-sliding's bristle state driven by the position with count-level
reversals removed — a play of 2 position quanta (half-width one quantum) before the LuGre state,
in its state and in its damping column alike; the friction's other columns unchanged."""
import numpy as np
import plant.calibration.fit as F
_orig_df = F.design_full


def _design_full(prep, spec, q=None, dq=None, ddq=None, t=None):
    names, X = _orig_df(prep, spec, q, dq, ddq, t)
    if spec.presliding_k is None or spec.backlash_width is not None or prep.position_resolution <= 0:
        return names, X
    qq = prep.q if q is None else q
    wj = np.gradient(F.play_operator(qq, 2.0 * prep.position_resolution), prep.dt_s)
    c = F.presliding_state(wj, spec.presliding_k, prep.dt_s)
    X = X.copy()
    for nm, col in (("coulomb", c), ("coulomb_pos", np.maximum(c, 0.0)), ("coulomb_neg", np.minimum(c, 0.0)),
                    ("presliding_damping", wj - np.abs(wj) * c)):
        if nm in names:
            X[:, names.index(nm)] = col
    if "stribeck" in names:
        w = dq if dq is not None else prep.dq
        X[:, names.index("stribeck")] = c * np.exp(-((w / spec.stribeck_vs) ** 2))
    return names, X


F.design_full = _design_full
