"""The optimisation: the evaluator of a genome, the genetic algorithm, penalties, evaluation cache, executors,
checkpoints and the run driver that writes a run directory."""
