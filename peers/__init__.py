"""Independent codes the solver and the wall cell are checked against (tests and benchmarks only)."""
