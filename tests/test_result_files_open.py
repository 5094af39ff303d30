"""The folders that `simulate`, `mesh`, `export` and a tiny `run` write with --out: every VTU opens in meshio (a
declared dependency) and in pyvista/VTK (as ParaView reads it) with the same points, cells and named arrays, the
text metadata decodes to the same labels in both, every .pvd steps through files that exist, and every folder
records the resolved config it ran (config.yaml) with its wall law (export's deck holds the 'embedded' law only,
so it runs a file without the calibrated law).

meshio stops the interpreter on a file it cannot read (a VTK string array: "Illegal data type 'String'"),
so it reads the files in a child process.
"""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from fem.io import field_values, read_pvd
from tests.subprocess_run import run_cli, run_command, tiny_run_file

pv = pytest.importorskip("pyvista")

#: A calibrated wall law with a slope, so that the recorded and printed law is not the default.
RUN_FILE = ("fidelity: {preset: coarse}\nscene: {Q_i: 0.1, trim: 2.0, deflection: 1.0}\n"
            "material: {wall_law: calibrated, wall_slope: 0.5}\n")
#: The run file of ``export``: the same scene under the 'embedded' wall law (the deck refuses another law).
EXPORT_FILE = "fidelity: {preset: coarse}\nscene: {Q_i: 0.1, trim: 2.0, deflection: 1.0}\n"
#: A GA of 2 designs over one generation, serial, coarse preset.
RUN_FILE_GA = tiny_run_file("deflection: 1.0", trim=2.0).replace("max_generations: 0", "max_generations: 1")

#: Reads each file named on the command line with meshio and prints what it holds as one JSON object.
MESHIO_READER = r"""
import json, sys
import meshio
import numpy as np
out = {}
for f in sys.argv[1:]:
    m = meshio.read(f)
    fd = {}
    for k, v in m.field_data.items():
        v = np.asarray(v)
        fd[k] = bytes(v.tolist()).decode("utf-8").split("\0")[:-1] if v.dtype == np.uint8 else v.ravel().tolist()
    out[f] = {"points": len(m.points), "cells": {b.type: len(b.data) for b in m.cells},
              "point_data": sorted(m.point_data), "cell_data": sorted(m.cell_data), "field_data": fd}
print(json.dumps(out))
"""

STATE_POINT = {"displacement", "log_strain", "log_strain_axial", "cauchy_stress", "von_mises", "J", "on_base"}
STATE_CELL = {"mixed_pressure", "region", "gauge_element"}
STATE_FIELD = {"scene", "state", "units", "wall_law", "wall_slope_per_MPa", "Q_MPa", "delta_mm", "fidelity_preset"}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """simulate and mesh of one run file, export of it under the 'embedded' wall law and a tiny run, each into its
    --out folder."""
    root = tmp_path_factory.mktemp("commands")
    cfg, cfg_export, cfg_run = root / "w.yaml", root / "e.yaml", root / "r.yaml"
    cfg.write_text(RUN_FILE)
    cfg_export.write_text(EXPORT_FILE)
    cfg_run.write_text(RUN_FILE_GA)
    files = {"simulate": cfg, "mesh": cfg, "export": cfg_export, "run": cfg_run}
    procs = {cmd: run_cli(cmd, files[cmd], "--out", root / cmd, *(("--no-progress",) if cmd == "run" else ()),
                          cwd=root, timeout=900) for cmd in files}
    for cmd, proc in procs.items():
        assert proc.returncode == 0, f"{cmd}: {proc.stderr}"
    return SimpleNamespace(root=root, cfg=cfg, files=files, procs=procs)


def _meshio_read(files: list[Path], keys: str = "names") -> dict | list:
    """What meshio reads of each file: ``{file name: ...}``, or with ``keys="paths"`` a list in the order of
    ``files`` (files of several folders may share a name)."""
    proc = run_command([sys.executable, "-c", MESHIO_READER, *map(str, files)], timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout)
    if keys == "paths":
        return [got[str(f)] for f in files]
    return {Path(k).name: v for k, v in got.items()}


def _vtk_files(folder: Path, recursive: bool = False) -> list[Path]:
    find = folder.rglob if recursive else folder.glob
    return sorted([*find("*.vtu"), *find("*.vtk")])


@pytest.mark.parametrize("command", ["simulate", "mesh", "run"])
def test_every_vtu_opens_in_meshio_and_pyvista_alike(written, command):
    """Every mesh file of the folder (of a run directory, in every sub-folder) opens in both readers alike."""
    folder = written.root / command
    files = _vtk_files(folder, recursive=command == "run")
    assert files
    for path, m in zip(files, _meshio_read(files, keys="paths")):
        g = pv.read(path)
        assert m["points"] == g.n_points and sum(m["cells"].values()) == g.n_cells, path.name
        assert set(m["point_data"]) == set(g.point_data) and set(m["cell_data"]) == set(g.cell_data), path.name
        fd = field_values(g.field_data)
        assert set(m["field_data"]) == set(fd), path.name
        for k, v in fd.items():  # the same labels and numbers in both readers
            assert m["field_data"][k] == (v if isinstance(v, list) else v.tolist()), (path.name, k)


def test_the_scene_files_hold_their_arrays_labels_and_units(written):
    folder = written.root / "simulate"
    scenes = json.loads((folder / "scenes.json").read_text())
    names = [k for k, v in scenes.items() if isinstance(v, dict)]
    assert names == ["intact", "trimmed_uncompensated", "trimmed"]
    got = _meshio_read(_vtk_files(folder))
    for name in names:
        n_el = scenes[name]["mesh"]["n_elements"]
        for delta, file, _ in read_pvd(folder / f"{name}.pvd"):
            m = got[file]
            assert m["cells"] == {"tetra10": n_el}
            assert STATE_POINT <= set(m["point_data"]) and STATE_CELL <= set(m["cell_data"]), file
            fd = m["field_data"]
            assert STATE_FIELD <= set(fd), file
            assert fd["scene"] == [name] and fd["state"] == [file[len(name) + 1:-len(".vtu")]]
            assert fd["delta_mm"] == [pytest.approx(delta)] and fd["fidelity_preset"] == ["coarse"]
            assert fd["wall_law"] == ["calibrated"] and fd["wall_slope_per_MPa"] == [0.5]
            units = dict(u.split("=", 1) for u in fd["units"])
            assert units["displacement"] == "mm" and units["cauchy_stress"] == "MPa"
            assert units["wall_slope_per_MPa"] == "1/MPa" and "unknown" not in units.values()
            fibres = got[file.replace(".vtu", "_fibres.vtu")]
            assert set(fibres["cells"]) == {"line"} and {"displacement", "fibre"} <= set(fibres["point_data"])
            assert {"fibre_log_strain", "fibre_force"} <= set(fibres["cell_data"]) and fibres["field_data"]["scene"] \
                == [name]
        assert scenes[name]["wall_law"] == "calibrated" and scenes[name]["wall_slope_per_MPa"] == 0.5
    for pvd in folder.glob("*.pvd"):  # ParaView's collections step through files that exist
        entries = read_pvd(pvd)
        assert entries and all((folder / f).is_file() for _, f, _ in entries)
        reader = pv.get_reader(str(pvd))
        assert reader.time_values == sorted({t for t, _, _ in entries})
        reader.read()


def test_the_mesh_file_holds_its_report(written):
    folder = written.root / "mesh"
    report = json.loads((folder / "mesh_report.json").read_text())
    m = _meshio_read([folder / "mesh.vtu"])["mesh.vtu"]
    assert m["cells"] == {"tetra10": report["n_elements"]} and m["points"] == report["n_nodes"]
    assert m["field_data"]["mesh_method"] == [report["method"]] and m["field_data"]["fidelity_preset"] == ["coarse"]
    assert m["field_data"]["n_elements"] == [report["n_elements"]]


@pytest.mark.parametrize("command", ["simulate", "mesh", "export"])
def test_every_folder_records_the_resolved_config_it_ran(written, command):
    from whisker_opt.config.model import dump_config, load_config

    path = written.root / command / "config.yaml"
    assert path.read_text() == dump_config(load_config(written.files[command]), command)
    cfg = load_config(path)
    law = ("embedded", 0.0) if command == "export" else ("calibrated", 0.5)
    assert (cfg.material.wall_law, cfg.material.wall_slope) == law
    assert cfg.fidelity.preset == "coarse" and cfg.scene.trim == 2.0
    assert f"wall_law: {law[0]}" in path.read_text() and "preset: coarse" in path.read_text()


def test_simulate_prints_the_wall_law(written):
    out = written.procs["simulate"].stdout
    assert "wall law: calibrated: c(Q) = 1 + 0.5·Q (material.wall_slope = 0.5 1/MPa) (material.wall_law)" in out
    assert "material.wall_slope = 0 is the 'embedded' law" not in written.procs["simulate"].stderr


def test_a_calibrated_law_without_slope_warns_once_where_scenes_are_solved(caplog):
    import whisker_opt.wiring as wiring
    from whisker_opt.config.model import WhiskerConfig

    load_config = WhiskerConfig.model_validate
    idle = load_config({"material": {"wall_law": "calibrated", "wall_slope": 0.0}})
    for cfg, command, lines in ((idle, "simulate", 1), (idle, "run", 1), (idle, "compensate", 1),
                                (idle, "calibrate", 0), (idle, "mesh", 0), (idle, "export", 0),
                                (load_config({"material": {"wall_law": "calibrated", "wall_slope": 0.2}}), "simulate", 0),
                                (load_config({}), "simulate", 0)):
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="whisker_opt"):
            wiring.warn_unread_keys(cfg, command)
        warned = [r for r in caplog.records if "wall_slope = 0 is the 'embedded' law" in r.getMessage()]
        assert len(warned) == lines, (command, cfg.material)
        assert all("\n" not in r.getMessage() for r in warned)


def test_a_folder_holding_a_run_of_another_config_keeps_its_config(tmp_path):
    from whisker_opt.config.model import WhiskerConfig, dump_config, load_config
    from whisker_opt.workflows import record_config

    run_cfg, other = WhiskerConfig.model_validate({"seed": 1}), WhiskerConfig.model_validate({"seed": 2})
    record_config(tmp_path, run_cfg)
    (tmp_path / "optimiser.json").write_text("{}")
    record_config(tmp_path, run_cfg)  # the same config: written again
    with pytest.raises(FileExistsError, match="holds a GA run of another config"):
        record_config(tmp_path, other)
    assert (tmp_path / "config.yaml").read_text() == dump_config(run_cfg)
    assert load_config(tmp_path / "config.yaml").seed == 1
