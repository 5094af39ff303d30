"""whisker-opt: design optimiser for soft, pneumatically tunable whisker sensors.

The pipeline, one design at a time:

1. **CAD** (:mod:`geometry`): a hollow, fibre-wound cone of base diameter D, length L and
   half-angle α, with a pressure chamber from the cap to x = l and a wall t thick.
2. **Mesh**: a template, swept or fresh tetrahedral mesh of quadratic elements, sized by a
   fidelity preset (``coarse``, ``default``, ``fine``).
3. **Nonlinear FE** (:mod:`fem`): incompressible neo-Hookean rubber with truss fibres. A
   scene pressurises the chamber to Q, then pushes the tip sideways to δ_max and reads the
   strain gauge ε(δ).
4. **Objective**: after trimming Δ mm off the tip, venting the chamber should restore the
   intact reading; f1 = mean |ε_intact(δ) − ε_trimmed(δ)|.
5. **GA** (DEAP, :mod:`whisker_opt.optimise`): searches the genome [α, l, t, Q_i] for the
   smallest penalised f1, writing a results directory you can resume, report and verify.

The Python API (:mod:`whisker_opt.api`), importable from this package::

    load_config(path_or_mapping)   validated config from a YAML file or a dict
    simulate(cfg, out=None)        the intact/trimmed scenes of one design -> Simulation
    evaluate(cfg, genes)           one GA evaluation of a genome -> EvalOutcome (f1, timings)
    run(cfg, out=None)             the GA -> RunSummary; results in a run directory
    resume(run_dir)                continue a killed run
    load_run(run_dir)              read a run directory back -> RunResults
    verify(run_dir, preset, top)   re-evaluate a run's best designs at a finer preset
    vent_pressure(trim, a, table)  the vent pressure Q(Δ, a) from a compensation map (CompensationMap)

Example::

    import whisker_opt as wo

    cfg = wo.load_config({"fidelity": {"preset": "coarse"}, "scene": {"Q_i": 0.2, "trim": 5.0}})
    print(wo.evaluate(cfg, {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}).f1)

The same jobs run from the shell as ``whisker-opt <command>`` (:mod:`whisker_opt.cli`);
``examples/`` holds short scripts. The API names are imported on first use (PEP 562), so
``import whisker_opt`` loads neither numpy nor the FE code.
"""

from __future__ import annotations

__all__ = ["__version__", "load_config", "simulate", "evaluate", "run", "resume", "load_run", "verify",
           "RunResults", "vent_pressure", "CompensationMap"]

_API_NAMES = frozenset(__all__) - {"__version__"}


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("whisker-opt")
    except metadata.PackageNotFoundError:
        return "0+unknown"


def __getattr__(name: str) -> object:
    """Import the API (and the version) on first access."""
    if name == "__version__":
        value = _version()
    elif name in _API_NAMES:
        from whisker_opt import api

        value = getattr(api, name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
