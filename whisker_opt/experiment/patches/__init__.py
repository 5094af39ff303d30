"""What the strain gauge adds to the surface it is bonded to, one module each, registered by name in
:mod:`whisker_opt.experiment.gauge_patches`."""
