"""The run file: typed, validated YAML sections (design, material, scene, fidelity, optimiser, output).

:mod:`whisker_opt.config.model` holds the sections and :func:`load_config`;
:mod:`whisker_opt.config.optimiser` the ``optimiser:`` section; :mod:`whisker_opt.config.base`
the strict pydantic base class. ``docs/config.md`` is generated from these models.
"""
