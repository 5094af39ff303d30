"""Independent codes the solver is checked against."""
