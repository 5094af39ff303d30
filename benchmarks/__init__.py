"""Benchmarks of whisker-opt: scripts that print tables, grouped by kind.

Run a script as a module from the repository root, e.g.
``python3 -m benchmarks.accuracy.time_vs_error --quick``. The sub-packages hold the scripts
(``performance``, ``accuracy``, ``studies``, ``reliability``); the modules beside them
(``common``, ``numerics``, ...) are what the scripts share. ``benchmarks/README.md`` is the index.
"""
