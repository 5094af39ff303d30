"""The pyvista viewer of run directories and result meshes."""
