"""Calibration loop: fit the plant model to measured records, find and name missing effects.

Modules: :mod:`~plant.calibration.io` (records), :mod:`~plant.calibration.fit` (IDIM-LS fit),
:mod:`~plant.calibration.residuals` (residual analysis), :mod:`~plant.calibration.loop` (effect
selection), :mod:`~plant.calibration.report` (``calibrate``: report.json/report.md/plots),
:mod:`~plant.calibration.model_file` (calibrated parameter file),
:mod:`~plant.calibration.emps_closed_loop` (EMPS closed-loop check),
:mod:`~plant.calibration.generate` (synthetic records), :mod:`~plant.calibration.bench_records` (an
independent record generator that imports nothing from plant/) and
:mod:`~host.calibration_benchmark` (the benchmark scoring). See docs/calibration.md.
"""
