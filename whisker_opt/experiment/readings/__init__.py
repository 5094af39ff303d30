"""The gauge readings, one module each, registered by name in :mod:`whisker_opt.experiment.gauge_variants`."""
