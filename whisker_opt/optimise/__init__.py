"""The optimisation: genetic algorithm, penalties, evaluation cache, executors, checkpoints
and the run driver that writes a run directory."""
