"""The reductions over variants, one module each, registered by name in :mod:`whisker_opt.optimise.aggregate`."""
