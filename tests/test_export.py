"""``whisker-opt export``: the CalculiX deck of a scene runs in CalculiX and agrees with the in-house solver;
STEP and STL of the solid are readable and hold the solid's volume.

The deck is checked against an independent code (CalculiX, ``ccx``) solving the exported file; the
in-house reference is the same scene in the displacement formulation with the deck's D1 (CalculiX has
no hybrid elements, so the deck writes a compressible rubber, K/μ = 1000).
"""

from __future__ import annotations

import os
import re
import sys
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from whisker_opt.config.model import load_config

CCX = shutil.which("ccx")


def _config(tmp_path: Path, **scene):
    text = ("fidelity:\n  preset: coarse\nscene:\n  pair: false\n  trim: 0.0\n"
            + "".join(f"  {k}: {v}\n" for k, v in scene.items()))
    path = tmp_path / "export.yaml"
    path.write_text(text)
    return path, load_config(path)


def _blocks(dat: str, kind: str, nset: str) -> dict[float, np.ndarray]:
    """``{time: rows}`` of the ``.dat`` blocks ``<kind> ... for set <nset> and time <t>``."""
    out = {}
    for m in re.finditer(rf"{kind}[^\n]*for set {nset} and time\s+(\S+)\n\n(.*?)(?:\n\n|\Z)", dat, re.S):
        rows = [[float(v) for v in line.split()[1 if kind == "displacements" else 0:]]
                for line in m.group(2).strip().splitlines()]
        out[float(m.group(1))] = np.array(rows)
    return out


@pytest.mark.skipif(CCX is None, reason="CalculiX (ccx) is not installed")
def test_exported_deck_runs_in_calculix_and_agrees_with_the_solver(tmp_path):
    """Coarse default design, Q = 0.05 MPa, tip pushed 1 mm; 4 increments per phase.

    CalculiX must finish both phases (pressurise, deflect). Against the in-house displacement
    formulation with the deck's D1 on the same mesh: the pressurised tip extension within 0.5 %
    (measured 0.13 %) and the contact force at δ = 1 mm within 3 % (measured 1.9 %; at Q = 0 the
    two agree to 1e-6, so the gap is the pressurised state's stiffness, within the two codes'
    different pressure loads on the quadratic faces).
    """
    from whisker_opt import wiring
    from whisker_opt.export import export
    from whisker_opt.experiment.scene import run_scene
    from whisker_opt.output.scene_deck import deck_d1

    path, cfg = _config(tmp_path, Q_i=0.05, deflection=1.0)
    res = export(cfg, tmp_path / "out", str(path), n_increments=4)
    deck = res.decks["scene"]
    text = deck.read_text()
    assert "*ELEMENT, TYPE=C3D10" in text and "TYPE=SPRINGA" in text and "*EQUATION" in text
    run = subprocess.run([CCX, "-i", deck.stem], cwd=deck.parent, capture_output=True, text=True, timeout=600,
                         env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert run.returncode == 0, run.stdout[-2000:]
    dat = deck.with_suffix(".dat").read_text()
    force = _blocks(dat, "total force", "CONTACT")
    disp = _blocks(dat, "displacements", "CONTACT")
    assert sorted(force) == [1.0, 2.0] and sorted(disp) == [1.0, 2.0]  # both phases finished
    assert np.allclose(disp[2.0][:, 1], -1.0)

    spec = wiring.scene_spec(cfg, wiring.design_from_config(cfg, 0.0), 0.05)
    from dataclasses import replace

    ref = run_scene(replace(spec, formulation="displacement", d1=deck_d1(spec.c10, spec.d1, 1000.0),
                            n_deflection_steps=4))
    dl_ccx = float(disp[1.0][:, 0].mean())
    f_ccx = -float(force[2.0][0, 1])
    print(f"tip extension: ccx {dl_ccx:.6g} mm, in-house {ref.delta_l:.6g} mm; "
          f"contact force at 1 mm: ccx {f_ccx:.6g} N, in-house {ref.contact_force[-1]:.6g} N")
    assert abs(dl_ccx / ref.delta_l - 1) < 5e-3
    assert abs(f_ccx / ref.contact_force[-1] - 1) < 3e-2


def _stl_triangles(path: Path) -> np.ndarray:
    """Triangles (n, 3, 3) of an ASCII or binary STL."""
    data = path.read_bytes()
    if data[:5] == b"solid" and b"facet" in data[:1000]:
        v = re.findall(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", data)
        return np.array(v, dtype=float).reshape(-1, 3, 3)
    n = int(np.frombuffer(data[80:84], dtype="<u4")[0])
    assert len(data) == 84 + 50 * n
    rec = np.frombuffer(data[84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
    return rec["v"].astype(float)


def test_step_and_stl_are_readable_and_hold_the_solid(tmp_path):
    """The STEP re-imported by cadquery is one solid of the CAD volume (to 1e-6); the STL is a closed
    triangulation (every edge shared by two triangles) whose enclosed volume (divergence theorem) is
    the solid's within 0.5 % (chordal tolerance 0.01 mm on radii of 1–9 mm)."""
    import cadquery as cq

    from geometry.cad import build_solid
    from whisker_opt.export import export

    path, cfg = _config(tmp_path, Q_i=0.0)
    res = export(cfg, tmp_path / "out", str(path))
    step, stl = res.solids["whisker"]
    volume = build_solid(cfg_design(cfg)).Volume()
    shape = cq.importers.importStep(str(step))
    solids = shape.solids().vals()
    assert len(solids) == 1 and abs(solids[0].Volume() / volume - 1) < 1e-6
    tri = _stl_triangles(stl)
    assert len(tri) > 100
    v_stl = abs(np.einsum("ni,ni->n", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)
    print(f"solid volume {volume:.6g} mm3, STL {v_stl:.6g} mm3 ({len(tri)} triangles)")
    assert abs(v_stl / volume - 1) < 5e-3
    keys = np.round(tri, 5).reshape(-1, 3)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    edges = np.sort(np.concatenate([ids[:, [0, 1]], ids[:, [1, 2]], ids[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)


def cfg_design(cfg):
    from whisker_opt import wiring

    return wiring.design_from_config(cfg, 0.0)


def test_export_refuses_a_rubber_the_deck_cannot_write(tmp_path):
    """One line naming the key, the value and what is allowed; exit status 2; nothing written."""
    path, _ = _config(tmp_path, Q_i=0.0)
    out = tmp_path / "never"
    run = subprocess.run([sys.executable, "-m", "whisker_opt.cli", "export", str(path), "--out", str(out),
                          "--set", "material.rubber=yeoh_dragon_skin_10"], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[1])
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "material.rubber" in lines[0] and "yeoh_dragon_skin_10" in lines[0]
    assert "neo_hookean" in lines[0] and not out.exists()
