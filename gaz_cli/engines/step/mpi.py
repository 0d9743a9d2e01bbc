"""``mpiexec -n P gaz simulate ... --engine step``: one run, its patches spread over P processes.

How it goes (docs/how-to/mpi.md; design and measurements: docs/explanation/step_scaling.md):

* :func:`main`, called by ``gaz``'s entry point when the environment says it was started by an
  MPI launcher (:data:`LAUNCH_SIZE`) or ``GAZ_MPI=1``: it imports mpi4py (one line naming
  ``pip install 'gaz[mpi]'`` if it is missing), then rank 0 runs the command as usual, alone:
  it validates, writes the database, the trajectory and the diagnostics, and prints. The
  other ranks run :func:`serve`: they print and write nothing.
* When the step engine starts a run on rank 0, it sends the scene, the state and the run's
  options to the others (:func:`.ranks.start`); they run the same steps
  (:func:`gaz_cli.engines.step.run`'s stepper, a recorder that keeps nothing), each first
  contact pass scanning their own patches (:mod:`.ranks`).
* When the command ends, rank 0 sends its exit status (the verdict): the other ranks exit
  with it, so an error (a bad option, a scene refused before the run) is one line from rank
  0 and a non-zero exit everywhere, nobody waiting. A command that fails *during* a run
  (rank 0 can no longer meet the others at the run's next exchange) ends every rank with
  MPI_Abort after its line.

Other commands, and other engines, run on rank 0 only; the other ranks wait for the verdict.
"""

from __future__ import annotations

import os
import signal
import sys
import traceback
import warnings

from gaz_cli.engines.step import ranks

LAUNCH_SIZE = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")
"""Variables an MPI launcher sets to the number of processes: MPICH's hydra (and Intel MPI:
PMI_SIZE; MPI_LOCALNRANKS), Open MPI (OMPI_COMM_WORLD_SIZE)."""

LAUNCH_RANK = ("PMI_RANK", "OMPI_COMM_WORLD_RANK")
"""Variables an MPI launcher sets to the process's rank (read before MPI starts, so that
only rank 0 speaks when mpi4py is missing)."""


def launched(environ=os.environ) -> bool:
    """Whether this process is one of several started by an MPI launcher (``GAZ_MPI=1``: yes
    whatever the environment; ``GAZ_MPI=0``: no)."""
    forced = environ.get("GAZ_MPI")
    if forced in ("0", "1"):
        return forced == "1"
    for name in LAUNCH_SIZE:
        try:
            if int(environ.get(name, "1")) > 1:
                return True
        except ValueError:
            continue
    return False


def _launch_rank(environ=os.environ) -> int:
    for name in LAUNCH_RANK:
        if environ.get(name, "").isdigit():
            return int(environ[name])
    return 0


def main(cli_main, argv=None) -> None:
    """Run ``cli_main(argv)`` (gaz's entry point, which exits) as rank 0 of an MPI run, the
    other ranks serving it (see the module docstring). Exits with rank 0's status everywhere."""
    try:
        from mpi4py import MPI
    except ImportError:
        if _launch_rank() == 0:
            print("gaz: error: gaz was started by mpiexec but mpi4py is not installed: pip install "
                  "'gaz[mpi]' (or set GAZ_MPI=0 to run each process on its own)", file=sys.stderr)
        sys.exit(1)
    comm = MPI.COMM_WORLD
    if comm.Get_size() == 1:
        cli_main(argv)
    ranks.COMM = comm
    if comm.Get_rank() != 0:
        sys.exit(serve(comm))
    code = 1
    try:
        cli_main(argv)  # exits
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # noqa: BLE001 - GAZ_DEBUG's traceback (cli_main turns the rest into exits)
        traceback.print_exc()
    if ranks.running():  # the others are inside a run rank 0 left: stop them all
        sys.stderr.flush()
        comm.Abort(code or 1)
    ranks.tell(("exit", code))
    sys.exit(code)


class _Discard:
    """The recorder of a rank other than 0: wants what rank 0's wants (the kernels then do the
    same work, and flush at the same steps), keeps nothing."""

    wants_progress = False
    want_images = False

    def __init__(self, job: dict):
        self.want_bounces = job["want_bounces"]
        self.want_collisions = job["want_collisions"]
        self.snapshot_every = job["every"]

    def __getattr__(self, name):  # add_bounces, add_collisions, add_snapshot, diagnostic, progress
        return lambda *args, **kwargs: None


def serve(comm) -> int:
    """A rank other than 0: run the steps rank 0 sends, until it sends its exit status;
    returns it. Prints nothing (warnings off, SIGINT ignored); an error that rank 0 cannot have
    met ends every rank (MPI_Abort)."""
    import numba

    from gaz_cli.engines import step
    from gaz_cli.errors import GazError

    warnings.simplefilter("ignore")
    # a Ctrl-C is rank 0's to report (mpiexec gives it to every rank): rank 0 says so in one line
    # and ends the others (MPI_Abort inside a run, its exit status outside one)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        kind, job = ranks.listen()
        if kind == "exit":
            return int(job)
        try:  # rank 0's threads (gaz simulate --threads): its options reach rank 0 only
            numba.set_num_threads(min(job["threads"], numba.config.NUMBA_NUM_THREADS))
            stepper = step._Stepper(job["scene"], job["state"], _Discard(job), job["detection"], job["max_passes"],
                                    job["patches"])
            stepper.steps_per_call = job["steps_per_call"]
            stepper.run()
        except GazError:  # raised by rank 0 too, at the same point (the numbers are the same)
            continue
        except BaseException:  # noqa: BLE001 - this rank alone: the others would wait forever
            comm.Abort(1)
