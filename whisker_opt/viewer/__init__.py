"""The pyvista viewer of run directories and result meshes, on screen or as PNG screenshots.

A *source* is a results directory or a single ``.vtu`` file; each VTU is one *state* of one
*scene* (``intact_deflected.vtu``), VTU files in a sub-folder form a *group* (``best/``,
``eval_12/``). A view shows the whisker warped by the displacement, coloured by a field
(the axial log strain by default), with the undeformed outline, the cavity, the fibres,
the gauge footprint, the contact point and the gauge reading; scenes side by side share
the camera, and each has its own colour range and scalar bar unless one shared range is asked
for (``--clim shared``). The picture says what the colours are, whose range each bar shows,
where the gauge reading is counted from, and names the markers in a legend.

Modules, each importing only those listed before it:

:mod:`~whisker_opt.viewer.guard`
    pyvista import guard, headless detection, the viewer's errors.
:mod:`~whisker_opt.viewer.sceneinfo`
    Facts about a scene (``scenes.json`` entries): design, Q, trim, gauge, readings.
:mod:`~whisker_opt.viewer.genome`
    The scenes of a genome from the run's config (:mod:`whisker_opt.wiring`).
:mod:`~whisker_opt.viewer.rubber`
    The run's own rubber law (its config's ``material`` section), for a stress a file does not store.
:mod:`~whisker_opt.viewer.rundir`
    Discovering the VTU states and metadata of a results directory.
:mod:`~whisker_opt.viewer.evaluations`
    ``--rank`` / ``--eval``: rows of ``evaluations.csv``, their meshes, re-runs.
:mod:`~whisker_opt.viewer.fields`
    Reading a VTU grid; the stored fields, and those an older file lacks (from :mod:`fem.post` and
    the run's law); choosing the colour field.
:mod:`~whisker_opt.viewer.state`
    A loaded state: warped smooth surfaces, curved edges, outline, titles.
:mod:`~whisker_opt.viewer.overlays`
    Gauge patch, contact point, fibre lines, panel text and headings.
:mod:`~whisker_opt.viewer.labels`
    Words on the picture: fonts, wrapped titles, scalar-bar titles, colour-range note, legend.
:mod:`~whisker_opt.viewer.colours`
    Colour ranges: each panel its own, or one shared.
:mod:`~whisker_opt.viewer.render`
    Plotter, layout, camera, drawing a state, screenshots, the interactive slider.
:mod:`~whisker_opt.viewer.plots`
    Convergence and response-curve images beside the screenshots.
:mod:`~whisker_opt.viewer.command`
    The ``whisker-opt view`` command (:data:`~whisker_opt.viewer.command.VIEW_COMMAND`).

No module imports pyvista at import time (:func:`whisker_opt.viewer.guard.require_pyvista`),
so the command registers, and prints its ``--help``, without the ``viewer`` extra.
"""
