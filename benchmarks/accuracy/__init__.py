"""Accuracy: errors against closed forms, mesh-refinement references and other codes."""
