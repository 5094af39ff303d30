"""Calibration: fit named model parameters to a prototype's own measurements (``whisker-opt calibrate``).

One concept per module:

:mod:`~whisker_opt.calibration.measurements`
    The observation files (CSV) of three kinds: ``extension`` Δl(Q), ``response`` ε(δ) or its ratio
    to a reference pressure, ``restore`` the pressure at which one whisker reads as another; each
    malformed value is refused in one line naming the file, the row and the column.
:mod:`~whisker_opt.calibration.parameters`
    The fitted parameters: any real-valued run-file key, by its dotted path, with bounds and a start.
:mod:`~whisker_opt.calibration.forward`
    What the model predicts for an observation: the finite-element scenes or the beam model, and the
    root search that turns a restore observation into a pressure.
:mod:`~whisker_opt.calibration.starts`
    Where the local fits start: a coarse deterministic scan of the parameter box, and whether two
    local fits agree.
:mod:`~whisker_opt.calibration.fit`
    The weighted least-squares fit (``scipy.optimize.least_squares`` with bounds) from the start and
    from the scan's best point, the covariance of the fitted values, which parameters the data
    determine, and the predictions of the held-out observations.
:mod:`~whisker_opt.calibration.report`
    What a calibration writes: ``calibration.json``, ``calibrated.yaml``, ``calibration.png`` and the
    printed summary.
:mod:`~whisker_opt.calibration.job`
    The job ``whisker-opt calibrate`` runs: check and read everything, then fit and write.

A calibrated model is opt-in: it is a run file of its own, named and dated, stating its data
source (docs/calibration.md); nothing here changes a default.
"""
