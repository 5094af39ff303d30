"""The base of every error the geometry layer raises for a design it cannot build or mesh.

A caller that tells a design's meshing failure apart from any other fault (the GA's evaluator
records it as ``mesh_failed``) catches :class:`GeometryError`, never a class name.
"""

from __future__ import annotations


class GeometryError(Exception):
    """A design the geometry layer cannot build, mesh, or place fibres in."""
