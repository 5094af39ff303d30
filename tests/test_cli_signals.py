"""SIGTERM and SIGHUP end a command as Ctrl-C does: one message naming the signal and how to continue, exit
status 128 + the signal's number, no traceback."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_run_ended_by_a_signal_says_so(tmp_path, sig):
    proc = subprocess.Popen([sys.executable, "-m", "whisker_opt.cli", "run", str(ROOT / "configs" / "demo.yaml"),
                             "--out", str(tmp_path / "run"), "--no-progress"], cwd=ROOT, stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True)
    environment = tmp_path / "run" / "environment.json"  # written as the first generation's evaluations start
    while not environment.exists():
        assert proc.poll() is None, proc.communicate()[1]
        time.sleep(0.01)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + int(sig), err
    assert f"interrupted by {sig.name}" in err and "whisker-opt resume" in err
    assert "Traceback" not in err
