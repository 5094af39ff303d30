"""One meaning per key: a trim or initial-pressure key that is set and that the running command does not
read is warned about in one line naming the key, its value and what the command uses instead
(:func:`whisker_opt.wiring.unread_keys`, :mod:`whisker_opt.config.readers`); nothing is refused.

Every job is entered with a config setting all three keys (``scene.trim``, ``scene.Q_i``,
``optimiser.trim``) to non-default values; the warning function is replaced by a recorder that
stops the job right after it warned, so no scene is solved. The command line and the Python API
are then run for real on the cheap cases (``mesh``, the API's ``evaluate``) to see the lines.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

import whisker_opt as wo
from whisker_opt import wiring
from whisker_opt.cli import main as cli
from whisker_opt.config.model import load_config
from whisker_opt.config.readers import COMMAND_READS, TRIM_AND_Q_KEYS

ROOT = Path(__file__).resolve().parents[1]
ALL_SET = {"fidelity": {"preset": "coarse"}, "scene": {"trim": 4.0, "Q_i": 0.15},
           "optimiser": {"trim": 3.0, "ga": {"population": 2, "n_elite": 0}, "stopping": {"max_generations": 0},
                         "executor": {"kind": "serial"}}}


class _Stop(Exception):
    """Raised by the recorder: the job warned and need not go on."""


@pytest.fixture()
def recorded(monkeypatch):
    calls = []

    def record(cfg, command, reads=None, trim=None):
        lines = wiring.unread_keys(cfg, command, reads, trim)
        calls.append((command, lines))
        raise _Stop

    monkeypatch.setattr(wiring, "warn_unread_keys", record)
    return calls


def _unread(lines):
    return sorted(line.split(" = ")[0] for line in lines)


@pytest.mark.parametrize("command", sorted(COMMAND_READS))
def test_each_command_names_every_set_key_it_does_not_read(command):
    cfg = wo.load_config(ALL_SET)
    lines = wiring.unread_keys(cfg, command)
    assert _unread(lines) == sorted(k for k in TRIM_AND_Q_KEYS if k not in COMMAND_READS[command])
    for line in lines:
        key = line.split(" = ")[0]
        value = {"scene.trim": "4", "scene.Q_i": "0.15", "optimiser.trim": "3"}[key]
        assert line.startswith(f"{key} = {value} has no effect in {command}, ") and "\n" not in line
    # keys at their defaults (or a section left out) are not "set": nothing to say
    assert wiring.unread_keys(wo.load_config({"fidelity": {"preset": "coarse"}}), command) == []


def test_what_is_used_instead_is_named():
    cfg = wo.load_config(ALL_SET)
    run = wiring.unread_keys(cfg, "run")
    assert "scene.trim = 4 has no effect in run, which trims by optimiser.trim = 3 mm" in run[0]
    assert "scene.Q_i = 0.15 has no effect in run, which takes Q_i from the gene Q_i" in run[1]
    assert "which trims by scene.trim = 4 mm" in wiring.unread_keys(cfg, "simulate")[0]
    assert "whose trims run from 0 to optimiser.trim = 3 mm" in wiring.unread_keys(cfg, "compensate")[0]
    given = wiring.unread_keys(cfg, "mesh", trim=2.0)
    assert _unread(given) == ["optimiser.trim", "scene.Q_i", "scene.trim"]
    assert "which is given the trim 2 mm (--trim)" in given[0]
    with pytest.raises(ValueError, match="command='nope' is not one of mesh, simulate"):
        wiring.unread_keys(cfg, "nope")


def test_a_key_set_to_the_value_used_in_its_place_is_not_named():
    """scene.trim equal to optimiser.trim changes nothing in run, nor optimiser.trim equal to scene.trim in
    simulate, nor scene.Q_i = 0 in mesh; one step off, each is named again."""
    for trim, named in ((3.0, []), (3.5, ["scene.trim"])):
        cfg = wo.load_config({"scene": {"trim": trim}, "optimiser": {"trim": 3.0}})
        assert _unread(wiring.unread_keys(cfg, "run")) == named
        assert _unread(wiring.unread_keys(cfg, "compensate")) == named  # its largest trim is optimiser.trim
        assert _unread(wiring.unread_keys(cfg, "simulate")) == ([] if trim == 3.0 else ["optimiser.trim"])
    assert _unread(wiring.unread_keys(wo.load_config({"scene": {"trim": 2.0}}), "mesh", trim=2.0)) == []
    assert _unread(wiring.unread_keys(wo.load_config({"scene": {"trim": 2.0}}), "mesh", trim=2.5)) == ["scene.trim"]
    # Q_i from the gene has no single value: a set scene.Q_i is named whatever it is
    assert _unread(wiring.unread_keys(wo.load_config({"scene": {"Q_i": 0.2}}), "run")) == ["scene.Q_i"]
    assert _unread(wiring.unread_keys(wo.load_config({"scene": {"Q_i": 0.2}}), "calibrate")) == ["scene.Q_i"]


@pytest.mark.parametrize("path", sorted((ROOT / "configs").glob("*.yaml")), ids=lambda p: p.name)
def test_the_shipped_configs_are_warned_only_of_values_that_differ(path):
    """Every line for a shipped run file names a value other than the one the command uses (the number after
    ``= `` in what it uses instead, when it names one); simulate_default.yaml's scene.trim, equal to its
    optimiser.trim, is never named by the GA's commands."""
    cfg = load_config(path)
    for command in COMMAND_READS:
        for line in wiring.unread_keys(cfg, command):
            value, instead = line.split(" = ", 1)[1].split(" has no effect in ", 1)
            used = instead.split(" (docs/config.md")[0].rsplit(" = ", 1)
            if len(used) == 2:
                assert float(used[1].split()[0]) != float(value), line
    if path.name == "simulate_default.yaml":
        assert cfg.scene.trim == wiring.optimiser_of(cfg).trim
        for command in ("run", "resume", "evaluate", "verify", "compensate", "robustness"):
            assert "scene.trim" not in _unread(wiring.unread_keys(cfg, command)), command


def _jobs(tmp_path, monkeypatch):
    """Each job entered with the all-set config: (command, call).

    ``verify`` refuses a run without a checkpoint before it warns, so its run directory's best designs
    are given (the config is still read from the directory)."""
    from whisker_opt import compensation, export, robustness, workflows
    from whisker_opt.analysis import verify
    from whisker_opt.analysis.verify import verify_run
    from whisker_opt.optimise.runner import run_config_path
    from whisker_opt.calibration.job import prepare

    cfg = wo.load_config(ALL_SET)
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "config.yaml").write_text(workflows.dump_config(cfg))
    genes = {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}
    monkeypatch.setattr(verify, "_best_of_run", lambda run, top: (
        load_config(run_config_path(run)), cfg.optimiser, [{"genes": genes}]))
    calib = ROOT / "configs" / "calibrate_thesis.yaml"
    return [
        ("mesh", lambda: workflows.mesh(cfg, tmp_path / "m", progress=False)),
        ("simulate", lambda: workflows.simulate(cfg, tmp_path / "s")),
        ("export", lambda: export.export(cfg, tmp_path / "x")),
        ("run", lambda: workflows.run(cfg, tmp_path / "r", progress=False)),
        ("resume", lambda: workflows.resume(run_dir, progress=False)),
        ("evaluate", lambda: workflows.evaluate(cfg, genes)),
        ("verify", lambda: verify_run(run_dir, "default", 1, progress=False)),
        ("compensate", lambda: compensation.compensate(cfg, tmp_path / "c", progress=False)),
        ("compensate", lambda: compensation.compensate_map(cfg, tmp_path / "cm", progress=False)),
        ("robustness", lambda: robustness.robustness(cfg, robustness.config_designs(cfg), tmp_path / "b")),
        ("calibrate", lambda: prepare(load_config(calib, settings=["scene.trim=4", "optimiser.trim=3"]), calib)),
    ]


def test_every_job_warns_with_its_own_command(tmp_path, recorded, monkeypatch):
    for command, call in _jobs(tmp_path, monkeypatch):
        with pytest.raises(_Stop):
            call()
        got, lines = recorded[-1]
        assert got == command, (got, command)
        want = set(TRIM_AND_Q_KEYS) - set(COMMAND_READS[command])
        if command == "robustness":  # the config's own design: its Q_i is scene.Q_i
            want.discard("scene.Q_i")
        if command == "calibrate":  # calibrate_thesis.yaml sets scene.Q_i, the settings the trims
            want = set(TRIM_AND_Q_KEYS)
        assert set(_unread(lines)) == want, (command, lines)


def test_the_command_line_warns_in_one_line_per_key_and_still_runs(tmp_path, caplog):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("fidelity: {preset: coarse}\nscene: {Q_i: 0.2}\noptimiser: {trim: 7.0}\n")
    levels = {n: logging.getLogger(n).level for n in ("", "whisker_opt", *cli.QUIET_LOGGERS)}
    try:
        with caplog.at_level(logging.WARNING, logger="whisker_opt"):
            assert cli.main(["mesh", str(cfg), "--out", str(tmp_path / "m"), "--no-progress"]) == 0
    finally:
        for n, level in levels.items():
            logging.getLogger(n).setLevel(level)
    err = [r.getMessage() for r in caplog.records if "has no effect" in r.getMessage()]
    assert len(err) == 2, err
    assert "scene.Q_i = 0.2 has no effect in mesh" in err[0] and "optimiser.trim = 7 has no effect in mesh" in err[1]
    assert (tmp_path / "m" / "mesh.vtu").is_file()


def test_the_python_api_warns_where_evaluate_ignores_the_scene_keys(caplog):
    cfg = wo.load_config({"fidelity": {"preset": "coarse"}, "scene": {"Q_i": 0.2, "trim": 4.0}})
    with caplog.at_level(logging.WARNING, logger="whisker_opt"):
        out = wo.evaluate(cfg, {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1})
    assert out.ok
    said = [r.getMessage() for r in caplog.records if "has no effect" in r.getMessage()]
    assert [m.split(",")[0] for m in said] == ["scene.trim = 4 has no effect in evaluate",
                                               "scene.Q_i = 0.2 has no effect in evaluate"]
