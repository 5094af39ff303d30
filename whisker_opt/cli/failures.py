"""A computation that the inputs allowed but that did not succeed, told in one line.

A scene whose nonlinear solve does not converge (:class:`fem.newton.SolveFailed`) or whose
mesh cannot be made (the mesher's errors) ends ``simulate``, ``compensate`` and ``mesh``
with exit status 3 and a line naming the scene, the load reached and the reason.
:func:`describe_failure` builds that line from the exception: the load path's last
converged fraction is in its report, and the scene (its name in ``simulate``, its
pressure, trim and contact ratio) and the step that failed (meshing, pressurising, placing the
contact, deflecting) are those the scene code leaves on the exception
(:func:`whisker_opt.experiment.scene.run_scene`, :func:`whisker_opt.output.scenes.solve_scenes`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

class ComputationFailed(RuntimeError):
    """A solve or a mesh that did not succeed on valid inputs (exit status 3)."""


def computation_errors() -> tuple[type[BaseException], ...]:
    """The exceptions that mean "this computation failed" rather than "this input is bad" or a bug.

    Returns
    -------
    tuple of type
        :class:`fem.newton.SolveFailed`, :class:`fem.linsolve.LinearSolverError`,
        :class:`fem.mesh.MeshError`, the mesher's errors of :mod:`geometry` and a contact that
        finds no node (:class:`whisker_opt.experiment.contact.ContactPlacementError`).
    """
    from fem.linsolve import LinearSolverError
    from fem.mesh import MeshError
    from fem.newton import SolveFailed
    from geometry.mesh import TemplateError
    from geometry.tagging import FibreLocationError
    from geometry.tetrahedralize import MeshingError
    from whisker_opt.experiment.contact import ContactPlacementError

    return (SolveFailed, LinearSolverError, MeshError, MeshingError, TemplateError, FibreLocationError,
            ContactPlacementError)


def _context(exc: BaseException) -> dict[str, Any]:
    """Scene name, spec and step that the scene code left on ``exc`` (those it knows)."""
    from whisker_opt.experiment.scene import FAILED_WHILE, FAILED_WITH
    from whisker_opt.output.scenes import FAILED_NAME

    found = {"scene": getattr(exc, FAILED_NAME, None), "spec": getattr(exc, FAILED_WITH, None),
             "step": getattr(exc, FAILED_WHILE, None)}
    return {k: v for k, v in found.items() if v is not None}


def _g(x: float) -> str:
    return f"{x:.4g}"


def _load_reached(exc: BaseException, step: str | None, spec: Any) -> str:
    """'0.42 MPa of 1 MPa' or '29.3 mm of 30 mm' from the failed increment's load fraction."""
    last = getattr(exc, "last", None)
    s = getattr(last, "s_start", None)
    if s is None:
        return ""
    if spec is not None and step == "pressurising":
        return f"reached Q = {_g(s * spec.Q)} MPa of {_g(spec.Q)} MPa"
    if spec is not None and step == "deflecting":
        return f"reached δ = {_g(s * spec.deflection)} mm of {_g(spec.deflection)} mm"
    return f"reached {100 * s:.3g} % of the load"


def _scene_words(ctx: dict[str, Any]) -> str:
    """'scene trimmed (Q=0.2 MPa, trim 5 mm)', or '' when the frames named no scene."""
    spec = ctx.get("spec")
    words = [f"scene {ctx['scene']}" if "scene" in ctx else ("the scene" if spec is not None else "")]
    if spec is not None:
        facts = [f"Q={_g(spec.Q)} MPa"]
        trim = getattr(spec.design, "trim", None)
        if trim is not None:
            facts.append(f"trim {_g(trim)} mm")
        a = getattr(spec, "contact_ratio", None)
        if a is not None and a != 1.0:
            facts.append(f"contact ratio {_g(a)}")
        words.append(f"({', '.join(facts)})")
    return " ".join(w for w in words if w)


def _reason(exc: BaseException) -> str:
    last = getattr(exc, "last", None)
    reason = getattr(last, "reason", "") or ""
    reports = getattr(exc, "reports", None) or []
    cuts = sum(getattr(r, "n_cutbacks", 0) for r in reports)
    text = reason or str(exc)
    if reason and cuts:
        text += f", after {cuts} cut-backs"
    return " ".join(text.split())


def describe_failure(exc: BaseException, command: str, out: Path | None = None,
                     scene_order: Iterable[str] = ()) -> str:
    """One line telling which scene failed, where, why, and what was kept.

    Parameters
    ----------
    exc : BaseException
        One of :func:`computation_errors`, with its traceback.
    command : str
        ``simulate``, ``compensate`` or ``mesh``.
    out : Path, optional
        The output folder; the scenes solved before the failure are listed from the VTU
        files there.
    scene_order : iterable of str
        The scene names in the order they are solved (``simulate``).

    Returns
    -------
    str
    """
    from fem.newton import SolveFailed

    try:
        ctx = _context(exc)
    except Exception:  # noqa: BLE001 - the description must never hide the failure itself
        ctx = {}
    from fem.linsolve import LinearSolverError

    step = ctx.get("step")
    scene = _scene_words(ctx)
    if isinstance(exc, SolveFailed):
        reached = _load_reached(exc, step, ctx.get("spec"))
        what = f"{scene or 'the solve'} did not converge" + (f" while {step}" if step else "")
        line = f"{what}: {reached}" + (": " if reached else "") + _reason(exc)
    else:
        what = "the linear solver failed" if isinstance(exc, LinearSolverError) else "meshing failed"
        if step and isinstance(exc, LinearSolverError):
            what += f" while {step}"
        line = (f"{scene}: " if scene else "") + f"{what} ({type(exc).__name__}: {' '.join(str(exc).split())})"
    if out is not None and command == "simulate":
        order = list(scene_order)
        failed = ctx.get("scene")
        candidates = order[: order.index(failed)] if failed in order else order
        kept = [n for n in candidates if any(Path(out).glob(f"{n}_*.vtu"))]
        if kept:
            line += f"; solved scenes kept in {out}: {', '.join(kept)} (VTU files; no curve.csv or scenes.json)"
        else:
            line += f"; no scene was solved before it, nothing kept in {out}"
    elif command == "compensate":
        line += "; the compensation table (or map) was not written"
    return line
