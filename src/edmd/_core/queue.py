"""Event calendar: one key per particle, O(1) amortised updates (G. Paul, J. Comput. Phys. 221, 615 (2007)).

Time is cut into ``nb`` buckets of width ``w`` starting at ``t_base``. Keys in the current bucket
(or earlier) live in a small indexed binary heap; keys in later buckets sit unsorted in doubly
linked lists; keys beyond the calendar (including ``inf``) sit in an overflow list that is
redistributed when the calendar wraps. Each particle is in exactly one place:

* ``loc[i] >= 0``: position in ``heap``;
* ``loc[i] = -2 - b``: in bucket ``b`` (``b == nb`` is the overflow list).

The arrays form :class:`.bundles.Calendar` (unpacked here as ``key, loc, nxt, prv, head, heap,
qi, qf``). State scalars: ``qi = [heap_size, current_bucket, nb, moved, cursor]``, ``qf = [t_base, 1/w,
w]``; ``moved`` counts the entries visited when a bucket is opened or the calendar wraps (the
calendar's own work: per event it stays O(1) when the bucket width fits the event rate).
"""

import numpy as np
from .jit import hot, jit, leaf
from .bundles import Calendar
from .prefetch import prefetch

QI_SIZE, QI_CUR, QI_NB, QI_MOVED, QI_CURSOR = 0, 1, 2, 3, 4
QF_BASE, QF_INV, QF_WIDTH = 0, 1, 2


@leaf
def _sift_up(heap, loc, key, pos):
    i = heap[pos]
    k = key[i]
    while pos > 0:
        parent = (pos - 1) >> 1
        p = heap[parent]
        if key[p] <= k:
            break
        heap[pos] = p
        loc[p] = pos
        pos = parent
    heap[pos] = i
    loc[i] = pos


@leaf
def _sift_down(heap, loc, key, pos, n):
    i = heap[pos]
    k = key[i]
    while True:
        c = 2 * pos + 1
        if c >= n:
            break
        hc = heap[c]
        kc = key[hc]
        if c + 1 < n:
            hc1 = heap[c + 1]
            if key[hc1] < kc:
                c += 1
                hc = hc1
                kc = key[hc1]
        if kc >= k:
            break
        heap[pos] = hc
        loc[hc] = pos
        pos = c
    heap[pos] = i
    loc[i] = pos


@leaf
def _bucket_of(t, qi, qf):
    """Bucket index for key ``t``: ``-1`` means the heap, ``nb`` the overflow list."""
    x = (t - qf[QF_BASE]) * qf[QF_INV]
    if x < qi[QI_CUR] + 1.0:
        return -1
    if x < qi[QI_NB]:
        return int(x)
    return qi[QI_NB]


@leaf
def _link(nxt, prv, head, loc, i, b):
    """Put ``i`` at the head of the list of bucket ``b``."""
    h = head[b]
    nxt[i] = h
    prv[i] = -1
    if h >= 0:
        prv[h] = i
    head[b] = i
    loc[i] = -2 - b


@leaf
def _insert(q, i, t):
    key, loc, nxt, prv, head, heap, qi, qf = q
    key[i] = t
    b = _bucket_of(t, qi, qf)
    if b < 0:
        n = qi[QI_SIZE]
        heap[n] = i
        qi[QI_SIZE] = n + 1
        _sift_up(heap, loc, key, n)
    else:
        _link(nxt, prv, head, loc, i, b)


@hot
def queue_update(q, i, t):
    """Give particle ``i`` the new key ``t`` (re-sorting it).

    At most one heap position changes its key (in place, the hole left by ``i``, or ``i``
    appended), so one sift, up or down, restores the heap: inlined into the event loop at
    every re-prediction site, each copy stays small.
    """
    key, loc, nxt, prv, head, heap, qi, qf = q
    pos = loc[i]
    b = _bucket_of(t, qi, qf)
    n = qi[QI_SIZE]
    fix = -1  # the heap position to restore
    up = True  # by a sift up (else down)
    if pos >= 0:
        if b < 0:  # stays in the heap with a new key
            fix = pos
            up = t < key[i]
        else:  # leaves the heap: its last entry fills the hole
            n -= 1
            qi[QI_SIZE] = n
            if pos != n:
                last = heap[n]
                heap[pos] = last
                loc[last] = pos
                fix = pos
                up = pos > 0 and key[heap[(pos - 1) >> 1]] > key[last]
    else:  # leaves its bucket list
        p = prv[i]
        s = nxt[i]
        if p >= 0:
            nxt[p] = s
        else:
            head[-2 - pos] = s
        if s >= 0:
            prv[s] = p
        if b < 0:  # joins the heap as its last entry
            heap[n] = i
            fix = n
            n += 1
            qi[QI_SIZE] = n
    key[i] = t
    if b >= 0:
        _link(nxt, prv, head, loc, i, b)
    if fix >= 0:
        if up:
            _sift_up(heap, loc, key, fix)
        else:
            _sift_down(heap, loc, key, fix, n)


@jit
def _wrap_calendar(q):
    """Start a new lap: move the overflow list into a calendar based at its earliest finite key.

    Returns ``False`` when every remaining key is infinite (no future event).
    """
    key, loc, nxt, prv, head, heap, qi, qf = q
    nb = qi[QI_NB]
    tmin = np.inf
    i = head[nb]
    while i >= 0:
        if key[i] < tmin:
            tmin = key[i]
        i = nxt[i]
        qi[QI_MOVED] += 1
    if tmin == np.inf:
        return False
    qf[QF_BASE] = tmin
    qi[QI_CUR] = 0
    i = head[nb]
    head[nb] = -1
    while i >= 0:
        s = nxt[i]
        _insert(q, i, key[i])
        i = s
    return True


@hot
def queue_top(q):
    """Index of the particle with the smallest key, or ``-1`` if every key is infinite."""
    key, loc, nxt, prv, head, heap, qi, qf = q
    while qi[QI_SIZE] == 0:
        cur = qi[QI_CUR] + 1
        if cur >= qi[QI_NB]:
            if not _wrap_calendar(q):
                return -1
            continue
        qi[QI_CUR] = cur
        i = head[cur]
        head[cur] = -1
        while i >= 0:
            s = nxt[i]
            n = qi[QI_SIZE]
            heap[n] = i
            qi[QI_SIZE] = n + 1
            qi[QI_MOVED] += 1
            _sift_up(heap, loc, key, n)
            i = s
    return heap[0]


@leaf
def warm_bucket(q):
    """Walk one step down the list of the bucket after the current one, loading its entry.

    Opening a bucket walks its linked list, each entry a load that waits on the one before (large
    N: none is in a cache). One step per event ahead of time leaves the list cached when it opens.
    The cursor (``qi[QI_CURSOR]``) restarts at the list's head whenever its entry has left that
    bucket; it is a hint only and changes no result.
    """
    key, loc, nxt, prv, head, heap, qi, qf = q
    b = qi[QI_CUR] + 1
    if b >= qi[QI_NB]:
        return
    c = qi[QI_CURSOR]
    if c >= 0 and loc[c] == -2 - b:
        c = nxt[c]
    else:
        c = head[b]
    qi[QI_CURSOR] = c
    if c >= 0:
        prefetch(nxt, c)
        prefetch(key, c)
        prefetch(loc, c)


@jit
def queue_build(q, keys, t_now, width, nb):
    """Fill an empty calendar with ``keys``; bucket ``0`` starts at ``t_now``."""
    key, loc, nxt, prv, head, heap, qi, qf = q
    head[:] = -1
    qi[QI_SIZE] = 0
    qi[QI_CUR] = 0
    qi[QI_NB] = nb
    qi[QI_CURSOR] = -1
    qf[QF_BASE] = t_now
    qf[QF_WIDTH] = width
    qf[QF_INV] = 1.0 / width
    for i in range(keys.shape[0]):
        _insert(q, i, keys[i])


def new_queue(n, nb):
    """Allocate the calendar arrays for ``n`` particles and ``nb`` buckets (tuple, see module doc)."""
    return Calendar(
        np.full(n, np.inf),
        np.zeros(n, np.int32),
        np.full(n, -1, np.int32),
        np.full(n, -1, np.int32),
        np.full(nb + 1, -1, np.int32),
        np.zeros(n, np.int32),
        np.zeros(5, np.int64),
        np.zeros(3, np.float64),
    )


def calendar_shape(keys, t_now, events_per_bucket=8.0):
    """Bucket width and count so that a bucket holds ~``events_per_bucket`` events.

    The event rate is estimated from the earliest finite predicted keys: ``k`` keys after
    ``t_now`` and those at ``t_now`` itself (a lattice start in cells mode has thousands of
    particles on cell faces) fall within the ``k``-th key after it. The calendar spans a few mean
    prediction horizons so that the overflow list stays small. ``keys`` are sorted in place (no
    copy of N keys at a load; the caller fills them again for :func:`queue_build`).

    Example:
        >>> keys = np.r_[np.zeros(3000), np.linspace(0.001, 1.0, 1000)]   # many events now
        >>> width, nb = calendar_shape(keys, 0.0, 4.0)
        >>> round(1.0 / width), nb   # 4000 events in the first time unit, 4 per bucket
        (1000, 2400)
    """
    n = keys.shape[0]
    keys.sort()
    dt = keys[np.searchsorted(keys, -np.inf, side="right") : np.searchsorted(keys, np.inf)]  # (the finite keys, sorted)
    dt -= t_now
    np.maximum(dt, 0.0, out=dt)  # (still sorted)
    later = dt[np.searchsorted(dt, 0.0, side="right") :]
    if later.size < 2:
        return 1.0, 1
    k = min(later.size - 1, max(8, n // 4))
    rate = (dt.size - later.size + k + 1) / later[k]
    width = events_per_bucket / rate
    v = 0.9 * (dt.size - 1)  # (np.quantile of dt, which is sorted, from the two values around it: no copy of dt)
    lo = int(v)
    horizon = np.quantile(dt[lo : lo + 2], v - lo) * 4.0
    nb = int(min(max(horizon / width, 16), 4 * n + 16))
    return float(width), nb
