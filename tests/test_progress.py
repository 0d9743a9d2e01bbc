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


def test_simulate_draws_rich_bar_to_the_end():
    """simulate's bar is rich's (progress.bar), as sweep's is: driven by the engine's reports
    and closed complete, it ends at 100 % with the simulated time and the event rate."""
    from rich.progress import Progress as RichProgress

    out = io.StringIO()
    bar = progress.Progress(1e-9, stream=out, after_s=0.0)
    bar.progress(0.0, 0)
    time.sleep(0.01)
    bar.progress(4e-10, 1000)
    assert isinstance(bar.bar, RichProgress)
    bar.close(complete=True)
    text = out.getvalue()
    assert "simulating" in text and "100%" in text and "events/s" in text and "of 1e-09 s" in text, text


def test_sweep_draws_the_same_bar():
    from rich.progress import Progress as RichProgress

    from gaz_cli.run.sweeps import _Bar

    with _Bar(3, True) as sweep_bar:
        assert isinstance(sweep_bar.progress, RichProgress)
        columns = [type(c).__name__ for c in sweep_bar.progress.columns]
        sweep_bar.update(done=3, failed=0, running=0)
    simulate_columns = [type(c).__name__ for c in progress.bar("simulating", "{task.fields[detail]}").columns]
    # the same bar, percentage and time left; the sweep adds its run count
    assert columns[:3] == simulate_columns[:3] and columns[-1] == simulate_columns[-1] == "TimeRemainingColumn"


def test_the_compile_notice_says_how_long_it_usually_takes():
    out = io.StringIO()
    bar = progress.Progress(1e-9, stream=out, after_s=0.0)
    deadline = time.monotonic() + 30
    while not bar.notice_shown and time.monotonic() < deadline:
        time.sleep(0.01)
    bar.close()
    assert out.getvalue().strip() == progress.NOTICE
    assert f"usually {progress.COMPILE_S}" in progress.NOTICE and "first run only" in progress.NOTICE


def test_a_notebook_gets_the_bar(monkeypatch):
    """In a Jupyter kernel (rich's test: an IPython ZMQ shell) progress is wanted though stderr is
    no terminal, the sweep shows its bar by default, and the bars' console draws in the cell."""
    import types

    import rich.console

    from gaz_cli.run.sweeps import _Bar

    assert not progress.wanted(False, io.StringIO())
    monkeypatch.setitem(sys.modules, "IPython", types.ModuleType("IPython"))
    monkeypatch.setattr(rich.console, "_is_jupyter", lambda: True)
    assert progress.wanted(False, io.StringIO()) and not progress.wanted(True, io.StringIO())
    assert progress.console().is_jupyter and progress.bar("simulating").console.is_jupyter
    assert _Bar(3, None).show
