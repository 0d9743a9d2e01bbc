"""gaz_cli.engines.event.calendar: the calendar queue gives the events in the order of the exam's
sorted catalogue (``reference.ajoutEv``), whatever its shape, with entries moved and removed
as the event loop moves and removes them."""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli.engines import reference
from gaz_cli.engines.event.calendar import (_build_queue, _heap_remove, _next_bucket, _q_insert,
                                            _q_remove)
from gaz_cli.engines.event.layout import NONE, QB, STATE


class Calendar:
    """The queue's arrays and the loop's calls around them (pop, insert, remove)."""

    def __init__(self, keys, width, nbk):
        n = keys.size
        self.EV = np.zeros((n, 4))
        self.EV[:, 2] = keys
        self.Q = np.zeros((n, 4), dtype=np.int32)
        self.Q[:, QB] = NONE
        self.HK, self.HI = np.zeros(n), np.zeros(n, dtype=np.int64)
        self.BH = np.full(nbk, -1, dtype=np.int64)
        S = np.zeros(1, STATE)
        st = S[0]
        st["nbk"], st["iw"], st["cur"] = nbk, 1.0 / width, 0
        _build_queue(self.EV, self.Q, self.HK, self.HI, self.BH, S)
        self.cur, self.nbk, self.iw = int(st["cur"]), nbk, 1.0 / width
        self.hsize, self.ohead = int(st["hsize"]), int(st["ohead"])

    def pop(self, t_stop):
        if self.hsize == 0:
            self.cur, self.hsize, self.ohead, _ = _next_bucket(
                self.Q, self.HK, self.HI, self.BH, self.EV, self.cur, self.nbk, self.iw,
                self.ohead, t_stop * self.iw)
        if self.hsize == 0 or self.HK[0] > t_stop:
            return None
        t, k = self.HK[0], int(self.HI[0])
        self.hsize = _heap_remove(self.HK, self.HI, self.Q, self.hsize, 0)
        self.Q[k, QB] = NONE
        return t, k

    def push(self, k, key):
        self.EV[k, 2] = key
        self.hsize, self.ohead = _q_insert(self.Q, self.HK, self.HI, self.BH, k, key, self.cur,
                                           self.nbk, self.iw, self.hsize, self.ohead)

    def remove(self, k):
        self.hsize, self.ohead = _q_remove(self.Q, self.HK, self.HI, self.BH, k, self.nbk,
                                           self.hsize, self.ohead)


@pytest.mark.parametrize("width, nbk", [(0.01, 16), (1.0, 16), (1e-4, 1 << 12), (0.3, 4)])
def test_events_come_out_in_the_exams_catalogue_order(width, nbk):
    """Random keys (some far beyond a turn of the calendar, some inf), then an event loop's
    traffic: each popped particle comes back later, and now and then a partner is taken out
    and put back with a new key. The pops are the exam's catalogue's, event for event (keys
    are distinct, so the order is unique), and everything left ends at inf."""
    rng = np.random.default_rng(nbk)
    n = 300
    keys = rng.exponential(1.0, size=n)
    keys[::37] = np.inf
    cal = Calendar(keys, width, nbk)
    catalogue = []
    for k in range(n):
        if np.isfinite(keys[k]):
            reference.ajoutEv(catalogue, [k, keys[k]])
    t_stop = 4.0
    for _ in range(20000):
        got = cal.pop(t_stop)
        want = catalogue.pop() if catalogue and catalogue[-1][1] <= t_stop else None
        if want is None:
            assert got is None
            break
        assert got == (want[1], want[0])
        t, k = got
        new = t + rng.exponential(1.0)
        cal.push(k, new)
        reference.ajoutEv(catalogue, [k, new])
        if rng.random() < 0.3:  # a collision partner: taken out, put back with a new key
            j = int(rng.integers(n))
            if j != k and np.isfinite(cal.EV[j, 2]):
                cal.remove(j)
                catalogue.remove([j, cal.EV[j, 2]])
                new = t + rng.exponential(1.0)
                cal.push(j, new)
                reference.ajoutEv(catalogue, [j, new])
    else:
        pytest.fail("the queue never emptied up to t_stop")
