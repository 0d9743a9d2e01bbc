"""The processes of an MPI run as the step engine sees them (issue 40, item 3; docs/how-to/mpi.md).

Under ``mpiexec -n P gaz simulate ... --engine step`` every process (rank) holds every particle
and runs the same steps; the patches (:mod:`.patches`) are spread over the ranks for the
first contact pass of each step, the scan of every particle for walls and pairs: rank r scans
the patches :func:`_owned` gives it (a slab of patches, the halo being the neighbour patches'
border cells, which every rank holds), then :func:`share_scans` gives every rank the candidates
of every patch (an allgather), in the same rows as one process would have written them. From
there every rank does the same serial resolution, earliest first, ties by identity, so the
numbers are those of one process, bit for bit. What is replicated, what is distributed and
what it costs: docs/explanation/step_scaling.md.

Rank 0 runs the command (:mod:`.mpi`): it sends each run's scene and state to the others
(:func:`start`), and alone writes and prints. This module holds the communicator (None outside
an MPI run) and what the kernels call; it imports no MPI itself (:mod:`.mpi` sets
:data:`COMM`).
"""

from __future__ import annotations

import os
import threading
import time

import numba
import numpy as np

from gaz_cli.numba_config import njit

COMM = None
"""The mpi4py communicator of an MPI run of the step engine (set by :func:`.mpi.main`); None
outside one."""

_CLOCKS = {"share": 0.0, "running": False}
"""Seconds spent in :func:`share_scans` (the allgather, waiting for the slowest rank
included) since the last :func:`start`, and whether a run is under way (between
:func:`start` and :func:`finish`)."""


WAIT_SLEEP_S = 5e-5
"""Seconds a rank sleeps between tests of a collective it waits for, after 100 yields."""


def size() -> int:
    """Processes of this run (1 outside MPI, and outside the main thread: runs in threads of
    one process, a sweep's, would mix their exchanges)."""
    if COMM is None or threading.current_thread() is not threading.main_thread():
        return 1
    return int(COMM.Get_size())


def rank() -> int:
    """This process's rank (0 outside MPI, and outside the main thread: :func:`size`)."""
    return 0 if size() == 1 else int(COMM.Get_rank())


def start(job: dict) -> None:
    """Rank 0: send a run to the other ranks (:func:`.mpi.serve` runs it) and start the clock of
    the shares. ``job``: scene, state and the run's options (see :func:`.mpi.serve`)."""
    _CLOCKS["share"] = 0.0
    if COMM is not None and size() > 1:
        tell(("run", job))
        _CLOCKS["running"] = True


CONTROL_TAG = 40
"""The MPI tag of rank 0's messages to the others (a run to serve, the exit status)."""


def tell(message) -> None:
    """Rank 0: send ``message`` (a pickled tuple) to every other rank."""
    for r in range(1, int(COMM.Get_size())):
        COMM.send(message, dest=r, tag=CONTROL_TAG)


def listen(poll_s: float = 0.01):
    """A rank other than 0: the next message of rank 0 (:func:`tell`), waited for by polling
    every ``poll_s`` s (a blocking receive would spin on a core while rank 0 validates,
    places and compiles, or runs another command or engine alone)."""
    while not COMM.Iprobe(source=0, tag=CONTROL_TAG):
        time.sleep(poll_s)
    return COMM.recv(source=0, tag=CONTROL_TAG)


def barrier() -> None:
    """Wait until every rank is here (nothing outside an MPI run)."""
    if COMM is not None and size() > 1:
        _wait(COMM.Ibarrier())


def finish() -> None:
    """The run's last exchange between ranks is over (rank 0 may fail from here on without
    leaving the others waiting inside it)."""
    _CLOCKS["running"] = False


def running() -> bool:
    """Whether rank 0 started a run whose exchanges are not all over."""
    return bool(_CLOCKS["running"])


def share_time() -> float:
    """Seconds this rank spent in :func:`share_scans` since the run started."""
    return _CLOCKS["share"]


@njit
def _owned(npatch, rank, nranks):
    """(lo, hi): the patches rank scans, a contiguous slab (patches are numbered along axis 1,
    then 2: :func:`.patches._patch_cells`); empty when there are fewer patches than ranks."""
    return rank * npatch // nranks, (rank + 1) * npatch // nranks


def share_scans(pci, pcj, pct, pk, pleft) -> None:
    """Every rank gets every patch's first-pass candidates, in place: patch p's ``pk[p]`` rows
    at p ccap... of pci, pcj, pct (ccap = rows / patches; rows beyond ccap counted, not
    written, as :func:`.passes._first_scan` leaves them) and its overlap tally pleft[p].

    Two allgathers: the patches' counts and tallies, then their rows (i, j, tau as float64,
    exact for indices below 2**53), each rank's patches in patch order."""
    t0 = time.perf_counter()
    from mpi4py import MPI

    nranks, me = size(), rank()
    npatch = pk.shape[0]
    ccap = pci.shape[0] // npatch
    lo, hi = _owned(npatch, me, nranks)
    head = np.zeros((npatch, 3))
    head[lo:hi, 0] = pk[lo:hi]
    head[lo:hi, 1:] = pleft[lo:hi]
    heads = np.empty((nranks, npatch, 3))
    _wait(COMM.Iallgather(head, heads))
    kept = np.zeros(nranks, np.int64)
    for r in range(nranks):
        a, b = _owned(npatch, r, nranks)
        pk[a:b] = heads[r, a:b, 0]
        pleft[a:b] = heads[r, a:b, 1:]
        kept[r] = np.minimum(pk[a:b], ccap).sum()
    rows = np.empty((int(kept[me]), 3))
    k = 0
    for p in range(lo, hi):
        s, m = p * ccap, min(int(pk[p]), ccap)
        rows[k:k + m, 0] = pci[s:s + m]
        rows[k:k + m, 1] = pcj[s:s + m]
        rows[k:k + m, 2] = pct[s:s + m]
        k += m
    every = np.empty((int(kept.sum()), 3))
    _wait(COMM.Iallgatherv(rows, [every, (kept * 3, np.concatenate(([0], np.cumsum(kept)[:-1])) * 3),
                                      MPI.DOUBLE]))
    k = 0
    for r in range(nranks):
        a, b = _owned(npatch, r, nranks)
        for p in range(a, b):
            s, m = p * ccap, min(int(pk[p]), ccap)
            if r != me:
                pci[s:s + m] = every[k:k + m, 0]
                pcj[s:s + m] = every[k:k + m, 1]
                pct[s:s + m] = every[k:k + m, 2]
            k += m
    _CLOCKS["share"] += time.perf_counter() - t0


def _wait(request) -> None:
    """Wait for a non-blocking collective, giving the core away between tests: MPICH's blocking
    wait spins, which on a core shared with other work (the ranks' own threads, other jobs)
    slows the rank being waited for."""
    spins = 0
    while not request.Test():
        spins += 1
        if spins < 100:
            os.sched_yield()
        else:
            time.sleep(WAIT_SLEEP_S)


@numba.njit(cache=True, nogil=False)
def _share(pci, pcj, pct, pk, pleft):
    """:func:`share_scans` from a kernel (object mode: mpi4py is Python; holds the GIL, hence
    not ``nogil``, unlike :data:`gaz_cli.numba_config.njit`)."""
    with numba.objmode():
        share_scans(pci, pcj, pct, pk, pleft)

