"""Studies: physics and model questions (wall laws, fibre models, model form, compensation, robustness, calibration)."""
