"""The linear solver: one registry by name (fem.linsolve) and the run file's ``fidelity.linear_solver``."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fem.linsolve import AUTO_ORDER, SOLVER_NAMES, SOLVERS, LinearSolver, make_solver
from whisker_opt.config.model import ConfigError, WhiskerConfig, load_config
from whisker_opt.wiring import scene_spec, with_preset


def test_every_registered_solver_follows_the_protocol_and_solves_a_saddle_point_system():
    rng = np.random.default_rng(0)
    K = sp.random(40, 40, density=0.2, random_state=1) + 10 * sp.eye(40)
    B = sp.hstack([sp.eye(5), sp.random(5, 35, density=0.3, random_state=2)])  # full row rank
    C = sp.hstack([sp.eye(5), sp.random(5, 35, density=0.3, random_state=3)])
    A = sp.bmat([[K, C.T], [B, None]], format="csr")  # non-symmetric, zero pressure block
    b = rng.standard_normal(45)
    assert SOLVER_NAMES == ("auto",) + tuple(SOLVERS) and set(AUTO_ORDER) <= set(SOLVERS)
    for name in SOLVERS:
        solver = make_solver(name)
        assert isinstance(solver, LinearSolver) and solver.name == name
        solver.factorize(A)
        x = solver.solve(b)
        assert np.linalg.norm(A @ x - b) <= 1e-9 * np.linalg.norm(b)
        solver.release()
    assert make_solver("auto").name == AUTO_ORDER[0]


def test_an_unknown_solver_is_refused_naming_the_allowed_ones():
    with pytest.raises(ValueError, match="linear_solver='cg': allowed 'auto', 'pardiso', 'superlu'"):
        make_solver("cg")


def test_the_run_file_key_reaches_the_scenes_newton_solver(tmp_path):
    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse", "linear_solver": "superlu"}})
    from geometry.design import WhiskerDesign

    spec = scene_spec(cfg, WhiskerDesign(), 0.1)
    assert spec.solve_options.linear_solver == "superlu"
    assert spec.solve_options.reuse_tangent == 0.3  # the scenes' other Newton controls are kept
    assert scene_spec(WhiskerConfig(), WhiskerDesign(), 0.1).solve_options.linear_solver == "auto"
    assert with_preset(cfg, "fine").fidelity.linear_solver == "superlu"


def test_a_bad_solver_in_a_run_file_is_one_line_naming_the_key(tmp_path):
    path = tmp_path / "run.yaml"
    path.write_text("fidelity:\n  linear_solver: mumps\n")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    msg = str(err.value)
    assert len(msg.splitlines()) == 1
    assert "fidelity.linear_solver" in msg and "'pardiso'" in msg and "'superlu'" in msg
