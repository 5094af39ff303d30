"""How the cap is joined to the body, one module per joint, registered by name in
:mod:`whisker_opt.experiment.cap_joints`."""
