"""A fit written in a test: a :class:`plant.calibration.fit.FitResult` with only the names and linear
parameters the loop's geometry rules read (``_replaces_inertia``, ``_removes_friction``), so a rule can be
checked on values chosen in the test instead of a fitted record."""

from __future__ import annotations

import numpy as np

from plant.calibration import fit

#: The baseline's linear parameters, in the design's order.
BASE = ("inertia", "viscous", "coulomb", "offset")


def stub_fit(names, coef) -> fit.FitResult:
    """A fit with parameters ``names`` = ``coef`` (same length); residuals and figures are zero."""
    n = 5
    z = np.zeros(n)
    return fit.FitResult(spec=fit.ModelSpec(), names=list(names), coef=np.asarray(coef, float), std=np.zeros(len(names)),
                         std_eff=np.zeros(len(names)), residual=z, yhat=z, rss=0.0, rms=0.0, relative_error_pct=0.0,
                         n=n, n_eff=float(n), n_params=len(names))
