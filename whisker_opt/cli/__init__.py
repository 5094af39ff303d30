"""The ``whisker-opt`` command line: a thin layer over :mod:`whisker_opt.workflows`; nothing imports it."""
