"""Solved scenes on disk: one VTU per kept state and the ``scenes.json`` entry of each scene.

The viewer (:mod:`whisker_opt.viewer`) reads what this module writes.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

logger = logging.getLogger(__name__)


def write_scene_vtus(out: Path, name: str, res) -> list[Path]:
    """Write the kept states of a scene result as ``<out>/<name>_<state>.vtu``.

    One file per state of :attr:`whisker_opt.experiment.scene.SceneResult.states`: ``pressurised``,
    ``delta_<δ>`` for every solved deflection increment but the last, and ``deflected``
    (the last increment, written once). Point array ``displacement`` [mm], cell array
    ``pressure`` (the element pressure unknown) [MPa].

    Parameters
    ----------
    out : Path
    name : str
        Scene name (file prefix).
    res : whisker_opt.experiment.scene.SceneResult
        Solved with ``keep_states=True``.

    Returns
    -------
    list of Path
    """
    from fem.io import write_vtu

    if not res.states:
        raise ValueError(f"scene {name!r}: no states kept; solve it with run_scene(..., keep_states=True)")
    last = res.states.get("deflected")
    paths = []
    for state_name, st in res.states.items():
        if state_name.startswith("delta_") and st is last:
            continue  # the same state as 'deflected'
        paths.append(write_vtu(out / f"{name}_{state_name}.vtu", res.mesh.mesh, point_data={"displacement": st.u},
                               cell_data={"pressure": st.p}))
    return paths


def scene_entry(spec, res, gauge_variant: str = "line", **extra) -> dict:
    """The ``scenes.json`` entry of a solved scene (read by :mod:`whisker_opt.viewer`).

    Parameters
    ----------
    spec : whisker_opt.experiment.spec.SceneSpec
    res : whisker_opt.experiment.scene.SceneResult
    gauge_variant : {'line', 'centroid'}
        Which gauge reading the curves use.
    **extra
        Further keys (e.g. ``wall_s``, ``genes``).
    """
    entry = {
        "design": spec.design.as_dict(),
        "Q_MPa": spec.Q,
        "trim": spec.design.trim,
        "delta_l_mm": res.delta_l,
        "length_q_mm": res.length_q,
        "contact_ratio": spec.contact_ratio,
        "contact_at": spec.contact_at,
        "contact_x": res.contact_x,
        "radial_growth_mm": res.radial_growth,
        "solved_delta_mm": res.delta.tolist(),
        "eps_line": res.eps_line.tolist(),
        "eps_centroid": res.eps_centroid.tolist(),
        "gauge_variant": gauge_variant,
        "timings_s": {k: round(v, 4) for k, v in res.timings.items()},
    }
    if res.mesh is not None:
        entry["mesh"] = res.mesh.report.as_dict()
    entry["reports"] = [r.as_dict() if hasattr(r, "as_dict") else str(r) for r in res.reports]
    entry.update(extra)
    return entry


def solve_scenes(out: Path, specs: dict, gauge_variant: str = "line", **extra) -> tuple[dict, dict]:
    """Solve scenes keeping their states; write their VTUs into ``out``.

    Parameters
    ----------
    out : Path
        Created when missing.
    specs : dict of str -> whisker_opt.experiment.spec.SceneSpec
        Scene name -> spec, solved in order.
    gauge_variant : {'line', 'centroid'}
    **extra
        Added to every ``scenes.json`` entry.

    Returns
    -------
    results : dict of str -> SceneResult
    entries : dict of str -> dict
        ``scenes.json`` entries (:func:`scene_entry`, with ``wall_s``).
    """
    from whisker_opt.experiment.scene import run_scene

    out.mkdir(parents=True, exist_ok=True)
    results, entries = {}, {}
    for name, spec in specs.items():
        t0 = time.perf_counter()
        res = run_scene(spec, keep_states=True)
        wall = time.perf_counter() - t0
        write_scene_vtus(out, name, res)
        results[name] = res
        entries[name] = scene_entry(spec, res, gauge_variant, wall_s=round(wall, 3), **extra)
        logger.info("scene %s: Q=%.4g MPa, trim=%.4g mm, eps(deflection)=%.6g, %.2f s", name, spec.Q,
                    spec.design.trim, res.eps_line[-1], wall)
    return results, entries
