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

import time

import numba

from gaz_cli.numba_config import njit

COMM = None
"""The mpi4py communicator of an MPI run of the step engine (set by :func:`.mpi.main`); None
outside one."""

_CLOCKS = {"share": 0.0, "running": False}
"""Seconds spent in :func:`share_scans` (the allgather, waiting for the slowest rank
included) since the last :func:`start`, and whether a run is under way (between
:func:`start` and :func:`finish`)."""


def size() -> int:
    """Processes of this run (1 outside MPI)."""
    return 1 if COMM is None else int(COMM.Get_size())


def rank() -> int:
    """This process's rank (0 outside MPI)."""
    return 0 if COMM is None else int(COMM.Get_rank())


def start(job: dict) -> None:
    """Rank 0: send a run to the other ranks (:func:`.mpi.serve` runs it) and start the clock of
    the shares. ``job``: scene, state and the run's options (see :func:`.mpi.serve`)."""
    _CLOCKS["share"] = 0.0
    if COMM is not None and size() > 1:
        COMM.bcast(("run", job), root=0)
        _CLOCKS["running"] = True


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
    written, as :func:`.passes._first_scan` leaves them) and its overlap tally pleft[p]."""
    t0 = time.perf_counter()
    npatch = pk.shape[0]
    ccap = pci.shape[0] // npatch
    lo, hi = _owned(npatch, rank(), size())
    mine = []
    for p in range(lo, hi):
        s, k = p * ccap, min(int(pk[p]), ccap)
        mine.append((pci[s:s + k].copy(), pcj[s:s + k].copy(), pct[s:s + k].copy()))
    for lo, hi, counts, left, rows in COMM.allgather((lo, hi, pk[lo:hi].copy(), pleft[lo:hi].copy(), mine)):
        pk[lo:hi] = counts
        pleft[lo:hi] = left
        for p, (ci, cj, ct) in zip(range(lo, hi), rows):
            s = p * ccap
            pci[s:s + ci.shape[0]] = ci
            pcj[s:s + ci.shape[0]] = cj
            pct[s:s + ci.shape[0]] = ct
    _CLOCKS["share"] += time.perf_counter() - t0


@numba.njit(cache=True, nogil=False)
def _share(pci, pcj, pct, pk, pleft):
    """:func:`share_scans` from a kernel (object mode: mpi4py is Python; holds the GIL, hence
    not ``nogil``, unlike :data:`gaz_cli.numba_config.njit`)."""
    with numba.objmode():
        share_scans(pci, pcj, pct, pk, pleft)

