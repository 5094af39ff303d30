"""The run file: typed, validated YAML sections (design, material, scene, fidelity, optimiser, output).

:mod:`whisker_opt.config.model` holds the sections and :func:`load_config`;
:mod:`whisker_opt.config.optimiser` the ``optimiser:`` section; :mod:`whisker_opt.config.base`
the strict pydantic base class; :mod:`whisker_opt.config.fields` what a field allows (range,
unit, words) and :mod:`whisker_opt.config.messages` the one-line error messages built from it.
``docs/config.md`` is generated from these models.
"""
