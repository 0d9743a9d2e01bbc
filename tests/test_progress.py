"""Progress on a terminal: the bar (and the compile notice) on stderr when it is a terminal,
nothing when stderr is a pipe or with --quiet. The CLI runs in a child process whose stderr
is a pseudo-terminal; GAZ_PROGRESS_AFTER=0 shows the bar on a run of a fraction of a second."""

import io
import os
import subprocess
import sys
import time

import pytest

from gaz_cli import progress

RUN = ["simulate", "--dim", "3", "--n", "100", "--length", "3.4e-8", "--duration", "1e-10",
       "--seed", "1", "--no-db", "--engine", "event"]


def gaz_on_terminal(*extra, terminal=True):
    """Run gaz with stderr on a pseudo-terminal (or a pipe); (exit code, stdout, stderr)."""
    env = {**os.environ, "GAZ_PROGRESS_AFTER": "0", "COLUMNS": "160"}
    cmd = [sys.executable, "-m", "gaz_cli", *RUN, *extra]
    if not terminal:
        res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
        return res.returncode, res.stdout, res.stderr
    master, slave = os.openpty()
    try:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=slave, env=env)
    finally:
        os.close(slave)
    err = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the child closed its end
            break
        if not chunk:
            break
        err += chunk
    os.close(master)
    out, _ = proc.communicate(timeout=300)
    return proc.returncode, out.decode(), err.decode(errors="replace")


def test_bar_on_a_terminal():
    code, out, err = gaz_on_terminal()
    assert code == 0, err
    assert "simulating" in err and "100%" in err and "events/s" in err, err
    assert "simulating" not in out and out.startswith("simulation (not stored)")


@pytest.mark.parametrize("how", ["pipe", "quiet"])
def test_nothing_on_a_pipe_or_with_quiet(how):
    code, out, err = gaz_on_terminal(*(["--quiet"] if how == "quiet" else []), terminal=how != "pipe")
    assert code == 0, err
    assert "simulating" not in err and progress.NOTICE not in err, err
    assert "events/s" in out  # the summary itself is unchanged


def test_compile_notice_only_while_the_engine_has_not_started():
    """The notice comes when the engine has not reported within after_s; an engine that
    reports at once (a warm cache) gets none."""
    slow, fast = io.StringIO(), io.StringIO()
    waiting = progress.Progress(1e-9, stream=slow, after_s=0.01)
    started = progress.Progress(1e-9, stream=fast, after_s=0.01)
    started.progress(0.0, 0)
    deadline = time.monotonic() + 30
    while not waiting.notice_shown and time.monotonic() < deadline:
        time.sleep(0.01)
    waiting.progress(0.0, 0)
    time.sleep(0.05)
    for bar in (waiting, started):
        bar.progress(1e-9, 10)
        bar.close()
    assert slow.getvalue().startswith(progress.NOTICE)
    assert progress.NOTICE not in fast.getvalue()


def test_wanted_only_on_a_terminal_without_quiet():
    master, slave = os.openpty()
    try:
        with os.fdopen(slave, "w", closefd=False) as tty:
            assert progress.wanted(False, tty) and not progress.wanted(True, tty)
    finally:
        os.close(master)
        os.close(slave)
    assert not progress.wanted(False, io.StringIO())
