"""Bodies of revolution: the axisymmetric finite-strain state and its Fourier-harmonic tangents.

* :mod:`fem.axisym.quad9`: the 9-node quadrilateral and its discontinuous linear pressure;
* :mod:`fem.axisym.meshgen2d`: structured Q9 meshes of the (R, Z) half-plane;
* :mod:`fem.axisym.harmonic`: the solid (axisymmetric residual and tangent, harmonic-n tangents);
* :mod:`fem.axisym.harmonic_pressure`: the follower pressure on its boundary edges;
* :mod:`fem.axisym.harmonic_solve`: the axisymmetric state as a :class:`fem.system.NonlinearSystem`
  (solved by :mod:`fem.newton` and :mod:`fem.loadpath`, as the 3-D solid) and the linear harmonic responses.
"""
