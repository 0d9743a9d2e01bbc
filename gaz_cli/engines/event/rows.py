"""A run's particle rows, cells and neighbour lists: loaded in space order, grown when full,
read back in the caller's order.

:class:`Rows` is the part of the driver's ``_Simulation`` that owns these arrays (see
:mod:`.layout` for their columns); the driver calls :meth:`Rows._load` at the start and at
every restart or rebase.
"""

from __future__ import annotations

import numpy as np

from gaz_cli.engines.event import sizing
from gaz_cli.engines.event.dynamics import _state_at
from gaz_cli.engines.event.layout import (DONE, EV_WIDTH, GATHER_SLOTS, I_WIDTH, NONE, P_WIDTH, PART,
                                          PART2, PR, PT, PV, QB, RANK)
from gaz_cli.engines.event.memory import _alloc, _morton
from gaz_cli.engines.event.neighbours import classes
from gaz_cli.engines.event.neighbours.cells import _assign_cells, wider
from gaz_cli.engines.event.neighbours.dilute import XC_SIZE, XS_ROWS
from gaz_cli.engines.event.neighbours.lists import _build_nl
from gaz_cli.engines.event.neighbours.wide import empty_blocks, wider_blocks
from gaz_cli.errors import EngineError


class Rows:
    """The particle rows P, I, EV, Q, the cells and the neighbour lists of one run (N
    particles, D dimensions, box L, nc cells an axis; set by the driver)."""

    def _wrap(self, x: np.ndarray) -> np.ndarray:
        """Positions x wrapped into the periodic box [0, L)^D."""
        x = x - self.L * np.floor(x / self.L)
        x[x >= self.L] = 0.0
        return x

    def _box_images(self, x: np.ndarray) -> np.ndarray:
        """The box lengths :meth:`_wrap` takes off positions x, (N, D) int64:
        x = _wrap(x) + images L."""
        k = np.floor(x / self.L)
        return (k + (x - self.L * k >= self.L)).astype(np.int64)

    def _fold_images(self, x: np.ndarray) -> np.ndarray:
        """Positions x (row order, now) wrapped, before a :meth:`_load` starts the rows afresh:
        the kernels' counts (IM) and this wrap's are added to ``images`` (caller's order)."""
        self.images[self.ident] += self.IM[:, :self.D] + self._box_images(x)
        return self._wrap(x)

    def _space_order(self, x: np.ndarray) -> np.ndarray:
        """Row order: along the line in 1D, cells along a Z-order curve in 2D/3D (stable).

        The Z (Morton) order keeps the 3^D cells around a particle within a
        few runs of rows, whichever axis they lie along; row-major cell order
        put the neighbours along the first axis nc^(D-1) cells away.
        """
        if self.D == 1:
            return np.argsort(x[:, 0], kind="stable")
        if not self.pairs:
            return np.arange(self.n)
        key = _morton(self._cell_coords(x))
        if key.size and int(key.max()) < (1 << 16):
            # the same order: numpy radix-sorts 16-bit keys, far faster than int64 ones
            # (measurements: docs/explanation/engine_measurements.md#event-engine-rows)
            key = key.astype(np.uint16)
        return np.argsort(key, kind="stable")

    def _cell_coords(self, x: np.ndarray) -> np.ndarray:
        """Integer cell coordinates (N, D) of positions x, rounded as the kernels round them."""
        a = self.L / self.nc
        return np.clip(np.floor(x / a).astype(np.int64), 0, self.nc - 1)

    def _load(self, x: np.ndarray, v: np.ndarray, t: float) -> None:
        """Fill the particle rows, cells and lists from positions x and velocities v at time t."""
        n, D, L, nc = self.n, self.D, self.L, self.nc
        P = _alloc((n, P_WIDTH), fill=0.0)
        P[:, :D] = x
        P[:, PV:PV + D] = v
        P[:, PT] = t
        P[:, PR] = self.R
        I = _alloc((n, I_WIDTH), np.int32, fill=0)
        I[:, PART] = -1
        I[:, PART2] = -1
        self.P, self.I = P, I
        self.IM = _alloc((n if self.periodic else 1, 3), np.int64, fill=0)  # wraps since now
        self.EV = _alloc((n, EV_WIDTH), fill=np.inf)
        self.Q = _alloc((n, 4), np.int32, fill=0)
        self.Q[:, QB] = NONE
        # 1D: rows are in line order, so row k has rank k
        self.order = np.arange(n, dtype=np.int64) if D == 1 else np.zeros(1, dtype=np.int64)
        if D == 1:
            I[:, RANK] = np.arange(n)
        self.XN = _alloc((n if self.use_nl else 1, 3), fill=0.0)
        if self.use_nl:
            self.XN[:, :D] = x
        if self.mix is not None:
            classes.fill(self, P, I)  # size classes: a fine table and a coarse one
        elif self.pairs and D > 1:
            c = self._cell_coords(x)
            key = c[:, 0]
            for d in range(1, D):
                key = key * nc + c[:, d]
            fullest = int(np.bincount(key, minlength=nc ** D).max())
            cap = max(self.cap, sizing._cell_capacity(n / nc ** D), fullest)
            while True:  # (the kernel's rounding decides; the loop is a safety net)
                self.cells = _alloc((nc ** D, sizing._cell_width(cap)), np.int32)
                if _assign_cells(P, I, self.cells, nc, L / nc, D) == DONE:
                    break
                cap *= 2
            self.cap = self.cells.shape[1] - 1
        else:
            self.cells = np.zeros((1, GATHER_SLOTS + 1), dtype=np.int32)
        self._gather_buffers()
        self.XS = _alloc((XS_ROWS, n if self.dilute else 1), np.float32, fill=0.0)  # filled by
        self.XC = np.zeros(XC_SIZE)  # the loop
        # wide cells: each cell's rows as a float32 block, filled by the loop
        self.XB = empty_blocks(nc ** D if self.wide else 1, self.cap if self.wide else 1)
        if self.use_nl:
            while True:
                self.NB = _alloc((n, self.nb_width), np.int32)
                self.NN = _alloc(n, np.int32, fill=0)
                self.SCR = np.empty(self.nb_width, dtype=np.int32)
                if _build_nl(P, self.XN, I, self.cells, self.NB, self.NN,
                             self.SCR, nc, L, self.h, D, self.periodic) == DONE:
                    break
                self.nb_width *= 2
        else:
            self.NB = np.zeros((1, 1), dtype=np.int32)
            self.NN = np.zeros(1, dtype=np.int32)
            self.SCR = np.zeros(1, dtype=np.int32)

    def _grow_lists(self) -> None:
        """Neighbour lists twice as wide (one overflowed)."""
        old = self.NB
        self.nb_width = 2 * old.shape[1]
        nb = _alloc((old.shape[0], self.nb_width), np.int32)
        nb[:, :old.shape[1]] = old
        self.NB = nb
        self.SCR = np.empty(self.nb_width, dtype=np.int32)

    def _grow_cells(self) -> None:
        """Cells with twice the room (one was full)."""
        self.cells = wider(self.cells)
        self.cap = self.cells.shape[1] - 1
        if self.wide:
            self.XB = wider_blocks(self.XB, self.cap)
        if self.mix is not None:
            classes.grow(self)
        self._gather_buffers()

    def _gather_buffers(self) -> None:
        """Room for two scans (a collision's partners) to gather every particle of 3^D full cells
        (GB) and their image shifts (GS)."""
        if self.cells.shape[1] < GATHER_SLOTS + 1:
            raise EngineError(f"cell rows of width {self.cells.shape[1]}: the scans copy "
                              f"{GATHER_SLOTS} slots a cell")
        room = 3 ** self.D * (self.cells.shape[1] - 1) + GATHER_SLOTS + 1
        if self.mix is not None:
            room = classes.gather_room(self)
        self.GB = np.empty(2 * room, dtype=np.int32)
        self.GS = np.empty(2 * room if self.periodic else 1, dtype=np.int32)

    def _state_internal(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) (N, D) in row order at time t on the kernels' clock."""
        x = np.empty((self.n, self.D))
        v = np.empty((self.n, self.D))
        _state_at(self.P, float(t), self.g, self.D, x, v)
        return x, v

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) (N, D) at time t in the caller's order, wrapped if periodic."""
        x, v, _ = self.snapshot_at(t)
        return x, v

    def snapshot_at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """(positions, velocities, images) at time t in the caller's order: as
        :meth:`state_at`, and in a periodic box each particle's box crossings since the run's
        start along each axis, (N, D) int64, exact (counted where the engine wraps it):
        positions + images L is the unwrapped position, positions of the start + the
        integral of the velocity. None with walls."""
        xi, vi = self._state_internal(t - self.origin)
        row_of = np.empty_like(self.ident)  # the row of each of the caller's particles
        row_of[self.ident] = np.arange(self.n)
        x = np.take(xi, row_of, axis=0)  # (a gather: 7x faster than x[ident] = xi)
        v = np.take(vi, row_of, axis=0)
        if not self.periodic:
            return x, v, None
        images = self.images.copy()
        images[self.ident] += self.IM[:, :self.D] + self._box_images(xi)
        return self._wrap(x), v, images
