"""Beyond one evaluation: the analytic beam model, compensation tables and the re-evaluation
of a run's best designs at another fidelity."""
