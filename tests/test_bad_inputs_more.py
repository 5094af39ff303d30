"""More bad inputs, each refused in one line with exit status 2, no traceback, nothing written.

In-process through ``whisker_opt.cli.main.main`` and cheap (nothing is solved): ``--set``
values YAML cannot turn into data (nested too deeply, integers of thousands of digits),
dask scheduler addresses that are no ``tcp://HOST:PORT``, keys given twice in a run file,
``output.name`` that is not a plain name, a ``compensate --step`` that makes more trims than
are allowed, ``init --force`` onto a FIFO or a socket, ``view --no-progress``, and wall laws or mesh sizes
that no evaluation could use (:data:`tests.bad_input_cases.MODEL_RANGES`) for ``mesh``, ``simulate`` and ``run``,
in a file and through ``--set``. A boolean
given for a number (``t: yes``) is a warning naming the key.
"""

from __future__ import annotations

import logging
import os
import socket
from pathlib import Path

import pytest

from tests.bad_input_cases import MODEL_RANGES, model_range_settings, runnable
from whisker_opt.cli import main as cli

GOOD = "fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.1\n  trim: 5.0\noptimiser:\n  trim: 2.0\n"

DEEP = "[" * 3000 + "]" * 3000
DEEP_MAP = "{a: " * 3000 + "1" + "}" * 3000
HUGE = "9" * 5000

#: (label, --set KEY=VALUE, words of the message)
SETTINGS = [
    ("deep list", f"design={DEEP}", ("--set", "nested too deeply")),
    ("deep mapping", f"design.t={DEEP_MAP}", ("--set", "nested too deeply")),
    ("deep list in a list", f"scene.deltas=[{DEEP}]", ("--set", "nested too deeply")),
    ("5000-digit seed", f"seed={HUGE}", ("--set", "too many digits")),
    ("5000-digit negative", f"design.t=-{HUGE}", ("--set", "too many digits")),
    ("5000-digit in a list", f"optimiser.objectives=[{HUGE}]", ("--set", "too many digits")),
    ("5000-digit population", f"optimiser.ga.population={HUGE}", ("--set", "too many digits")),
    ("5000-digit port", f"optimiser.executor.n_workers={HUGE}", ("--set", "too many digits")),
]

ADDRESSES = ["not-an-address", "tls://", "inproc://", "ucx://", "tcp://", "tcp://:8786", "tcp://host:",
             "tcp://host:0", "tcp://host:65536", "tcp://host:port", "host", ":8786", "ws://host:8786",
             "http://host:8786", "tcp://ho st:8786", "tcp://host:8786/path", "tcp://[::1", "inproc://127.0.0.1/1/2"]

#: (label, YAML text, words)
DUPLICATES = [
    ("design.t twice", "design:\n  t: 3\n  t: 4\n", ("'t'", "twice", "lines 2 and 3")),
    ("section twice", "design:\n  t: 3\ndesign:\n  l: 14\n", ("'design'", "twice")),
    ("flow mapping", "design: {t: 3, t: 4}\n", ("'t'", "twice")),
    ("seed twice", "seed: 1\nseed: 2\n", ("'seed'", "twice")),
    ("nested section", "optimiser:\n  ga:\n    population: 4\n    population: 6\n", ("'population'", "twice")),
    ("in a list item", "calibration:\n  parameters:\n    - {path: material.C10, path: x}\n", ("'path'", "twice")),
]

NAMES = ["../../evil", "..", ".", "/tmp/absolute", "a/b", "a\\\\b", "sub/../x", "' '", "./x", "x/"]

STEPS = ["0.000001", "0.0001", "0.001", "1e-9", "0.0019"]


def _run(capsys, *argv) -> tuple[int, list[str]]:
    code = cli.main([str(a) for a in argv])
    err = capsys.readouterr().err
    return code, [ln for ln in err.splitlines() if ln.strip()]


def _refused(code: int, lines: list[str], words) -> None:
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert "Traceback" not in lines[0]
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])


@pytest.fixture
def good(tmp_path) -> Path:
    p = tmp_path / "good.yaml"
    p.write_text(GOOD + f"output:\n  results_dir: {tmp_path / 'results'}\n")
    return p


@pytest.mark.parametrize("label, item, words", SETTINGS, ids=[s[0] for s in SETTINGS])
def test_unreadable_set_values_are_one_line(tmp_path, capsys, good, label, item, words):
    out = tmp_path / "out"
    code, lines = _run(capsys, "mesh", good, "--set", item, "--out", out)
    _refused(code, lines, words)
    assert len(lines[0]) < 400 and not out.exists()


@pytest.mark.parametrize("address", ADDRESSES)
def test_malformed_scheduler_addresses_are_refused(tmp_path, capsys, good, address):
    out = tmp_path / "out"
    code, lines = _run(capsys, "run", good, "--set", "optimiser.executor.kind=dask", "--set",
                       f"optimiser.executor.scheduler_address={address}", "--out", out, "--no-progress")
    # "tcp://host:" is a YAML mapping: refused by its type
    _refused(code, lines, ("scheduler_address",) if address.endswith(":") else ("scheduler_address", "tcp://HOST:PORT"))
    assert not out.exists()


@pytest.mark.parametrize("address", ["tcp://node1:8786", "node1:8786", "tls://10.0.0.1:8786", "tcp://[::1]:8786"])
def test_well_formed_scheduler_addresses_are_accepted(address):
    from whisker_opt.config.optimiser import check_scheduler_address

    check_scheduler_address(address)


@pytest.mark.parametrize("label, text, words", DUPLICATES, ids=[d[0] for d in DUPLICATES])
def test_a_key_given_twice_is_refused(tmp_path, capsys, label, text, words):
    cfg = tmp_path / "dup.yaml"
    cfg.write_text(text)
    code, lines = _run(capsys, "mesh", cfg, "--out", tmp_path / "out")
    _refused(code, lines, ("dup.yaml", *words))
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", NAMES)
def test_output_name_must_be_a_plain_name(tmp_path, capsys, name):
    cfg = tmp_path / "name.yaml"
    cfg.write_text(GOOD + f"output:\n  results_dir: {tmp_path / 'results'}\n  name: {name}\n")
    code, lines = _run(capsys, "mesh", cfg)
    if name == "' '":
        _refused(code, lines, ("output.name",))
    else:
        _refused(code, lines, ("output.name", "plain name"))
    assert not (tmp_path / "results").exists() and not (tmp_path.parent / "evil").exists()


@pytest.mark.parametrize("key, text", [("design.t", "t: yes"), ("design.l", "l: on"), ("design.alpha", "alpha: no"),
                                       ("design.t", "t: true")])
def test_a_boolean_for_a_length_is_a_warning_naming_the_key(tmp_path, capsys, caplog, key, text):
    cfg = tmp_path / "b.yaml"
    cfg.write_text(f"design:\n  {text}\n")
    with caplog.at_level(logging.WARNING):
        code, lines = _run(capsys, "mesh", cfg, "--trim", "80", "--out", tmp_path / "out")  # refused after loading
    assert code == 2 and "Traceback" not in "".join(lines)
    assert any(key in r.getMessage() and "boolean" in r.getMessage() for r in caplog.records), caplog.text


@pytest.mark.parametrize("step", STEPS)
def test_a_step_of_too_many_trims_is_refused(tmp_path, capsys, good, step):
    out = tmp_path / "out"
    for extra in ([], ["--map"]):
        code, lines = _run(capsys, "compensate", good, "--step", step, *extra, "--out", out)
        _refused(code, lines, ("--step", "trims", "at most 1000"))
    assert not out.exists()


def test_init_force_refuses_a_fifo_and_a_socket(tmp_path, capsys):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    sock_path = tmp_path / "sock"
    sock = socket.socket(socket.AF_UNIX)
    try:
        sock.bind(str(sock_path))
        for target in (fifo, sock_path):
            code, lines = _run(capsys, "init", target, "--force")
            _refused(code, lines, (str(target), "not a regular file"))
        assert fifo.is_fifo() and sock_path.is_socket()
    finally:
        sock.close()


def test_view_accepts_no_progress(tmp_path, capsys):
    code, lines = _run(capsys, "view", tmp_path / "missing", "--no-progress")
    _refused(code, lines, ("missing",))
    assert "unrecognized" not in lines[0]


def test_a_contact_on_the_fixed_base_fails_in_one_line(tmp_path, capsys):
    """scene.contact_ratio so small that the pusher's band reaches the fixed base: one error line naming the
    key, exit 3, no traceback (it was a ProblemError traceback: two Dirichlet sets on the same DOF)."""
    config = Path(__file__).resolve().parents[1] / "configs" / "simulate_default.yaml"
    code, lines = _run(capsys, "simulate", config, "--preset", "coarse", "--set",
                       "scene.contact_ratio=0.001", "--out", tmp_path / "out", "--no-progress")
    errors = [ln for ln in lines if "error" in ln]
    assert code == 3 and len(errors) == 1 and not any("Traceback" in ln for ln in lines), lines
    assert "scene.contact_ratio" in errors[0] and "fixed base" in errors[0]


@pytest.mark.parametrize("command", ["mesh", "simulate", "run"])
@pytest.mark.parametrize("label", list(MODEL_RANGES))
def test_a_wall_law_or_mesh_size_no_evaluation_can_use_is_refused_at_validation(tmp_path, capsys, label, command):
    """Was: a traceback from the scene or the mesher once solving began (simulate, mesh), or every design of
    a run failed and it ended with status 0 or a traceback from its best design's re-solve."""
    text, words = MODEL_RANGES[label]
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(runnable(text))
    extra = ["--no-progress"] if command == "run" else []
    _refused(*_run(capsys, command, cfg, "--out", tmp_path / "out", *extra), words)
    good = tmp_path / "good.yaml"
    good.write_text(runnable("{}"))
    _refused(*_run(capsys, command, good, *model_range_settings(text), "--out", tmp_path / "out", *extra), words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml", "good.yaml"]  # nothing written
