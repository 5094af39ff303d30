"""A design the geometry layer cannot build or mesh is told apart from a solver fault by its class:
every error class of ``geometry/`` derives from :class:`geometry.errors.GeometryError`, which the
GA's evaluator records as ``mesh_failed``."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import geometry
from fem.linsolve import LinearSolverError
from fem.mesh import MeshError
from fem.newton import SolveFailed
from geometry.errors import GeometryError
from whisker_opt.optimise.evaluator import _is_mesh_error


def _geometry_error_classes():
    out = []
    for info in pkgutil.iter_modules(geometry.__path__):
        mod = importlib.import_module(f"geometry.{info.name}")
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if issubclass(cls, BaseException) and cls.__module__ == mod.__name__:
                out.append(cls)
    return out


def test_every_geometry_error_is_a_geometry_error():
    classes = _geometry_error_classes()
    assert {c.__name__ for c in classes} >= {"MeshingError", "TemplateError", "FibreLocationError",
                                             "InvalidDesignError", "GeometryError"}
    assert [c.__name__ for c in classes if not issubclass(c, GeometryError)] == []


def test_mesh_failures_are_told_from_solver_faults():
    for cls in _geometry_error_classes():
        assert _is_mesh_error(cls.__new__(cls)), cls  # the class decides, not the message
    assert _is_mesh_error(MeshError("inverted tet"))
    assert not _is_mesh_error(SolveFailed("no convergence", []))
    assert not _is_mesh_error(LinearSolverError("singular"))
    assert not _is_mesh_error(ValueError("a plain value error"))
