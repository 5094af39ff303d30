"""The rubber laws, one module each, registered by name in :mod:`whisker_opt.experiment.rubber_laws`."""
