"""gaz analyse stopped by SIGINT or SIGTERM: one line on stderr, exit 128 + signal, nothing on stdout.

The signal is sent by the analysing process to itself from inside the analysis (a patched
step of it), so that it lands there every time, whatever the machine's speed.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

import pytest

from gaz_cli.run import runner
from gaz_cli.model.scene import Scene
from gaz_cli.model.species import lookup

CHILD = textwrap.dedent("""
    import os, signal, sys
    from gaz_cli import cli
    from gaz_cli.analysis import report as analysis
    from gaz_cli.analysis import studies

    signum = int(sys.argv[1])
    target = analysis if sys.argv[2] == "load_run" else studies
    real = getattr(target, sys.argv[2])

    def signalled(*args, **kw):
        os.kill(os.getpid(), signum)
        return real(*args, **kw)

    setattr(target, sys.argv[2], signalled)
    cli.main(sys.argv[3:])
""")


@pytest.fixture(scope="module")
def db(tmp_path_factory):
    """One run of the exam's own engine (no JIT to wait for), a few ms long."""
    path = str(tmp_path_factory.mktemp("sig") / "g.db")
    scene = Scene(dim=2, length=1e-7, duration=2e-10, components=((lookup("Ar"), 20),), seed=1,
                  engine="reference")
    runner.simulate(scene, db=path)
    return path


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("where, args", [("load_run", ["--sim", "1"]), ("versus", ["--vs", "n"])],
                         ids=["sim", "vs"])
def test_a_signal_stops_analyse_with_one_line(db, signum, where, args):
    """Before: SIGTERM ended ``gaz analyse`` with exit 143 and not a word on stderr."""
    proc = subprocess.run([sys.executable, "-c", CHILD, str(int(signum)), where, "analyse", "--db", db, *args],
                          capture_output=True, text=True, timeout=120)
    name = signal.Signals(signum).name
    assert proc.returncode == 128 + signum, (proc.returncode, proc.stderr)
    assert proc.stdout == ""
    assert proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith(f"gaz: interrupted by {name}; the analysis stopped before printing"), proc.stderr


EARLY_CHILD = textwrap.dedent("""
    import os, signal, sys
    from gaz_cli import cli

    # SIGINT as a terminal's Ctrl-C finds it: a process started with SIGINT ignored (a job sent
    # to the background by a script, as CI may run the suite) keeps it ignored, and Python then
    # installs no KeyboardInterrupt for it
    signal.signal(signal.SIGINT, signal.default_int_handler)

    class SignalOnImport:
        '''Sends the signal to this process when the command first imports module sys.argv[2].'''

        def find_spec(self, name, path=None, target=None):
            if name == sys.argv[2]:
                sys.meta_path.remove(self)
                os.kill(os.getpid(), int(sys.argv[1]))
            return None

    sys.meta_path.insert(0, SignalOnImport())
    cli.main(sys.argv[3:])
""")


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("module", ["numpy", "gaz_cli.analysis.report"])
def test_a_signal_during_analyses_imports_is_one_line(db, signum, module):
    """The signal lands while ``gaz analyse`` imports NumPy (the first of about a second of
    imports) or the analysis module: the process sends it to itself from the import system, so
    that it lands there every time. Before: SIGTERM ended the process without a word (returncode
    -15, stderr empty); SIGINT said 'nothing was written for the interrupted run'."""
    proc = subprocess.run([sys.executable, "-c", EARLY_CHILD, str(int(signum)), module, "analyse", "--db", db,
                           "--sim", "1"], capture_output=True, text=True, timeout=120)
    name = signal.Signals(signum).name
    assert proc.returncode == 128 + signum, (proc.returncode, proc.stderr)
    assert proc.stdout == ""
    assert proc.stderr == f"gaz: interrupted by {name}; the analysis stopped before printing its tables\n", proc.stderr
