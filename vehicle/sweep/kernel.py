"""The batched engine's time loop, compiled: exact step, Wk weighting and figure sums in one pass.

For every case of a group and every sample ``k`` the loop computes

* the exact step of the seated system and its outputs,
  ``[x_{k+1}; y_k] = M x_k + g_z z_k + g_v v_k``, ``M = [Phi; C_out]``
  (``(n + 4) x n``); the outputs are the head and seat acceleration and the neck
  and lumbar forces. A car driven at several road points (the wheels of a half or a
  full car) has one state: each point's road enters through its own input columns,
  ``M x_k + sum_p (g_z z + g_v v)_p``, summed point by point after the state's terms;
* the ISO 2631-1 Wk weighting of the head and the seat acceleration, the analog
  filter advanced exactly over the straight line between two samples
  (:class:`bodyvib.comfort.stream.WkFilter`'s recursion, evaluated sample by sample);
  of a car whose seat gives them, the seat's x and y acceleration (``M``'s last two
  rows) with two more weightings (Wd and We), in the same pass over the lanes;
* the running sums the figures come from: ``sum a_w^2``, ``sum a_w^4``,
  ``max |a_w|``, the largest 1 s sum of ``a_w^2`` (the MTVV), and the largest
  ``|force|``; of the seat's x and y, ``sum a_w^2``;
* the largest value of each *watched* output row after the forces (a car with tire
  contacts and stops: its switching functions, scaled so that 1 is the switching,
  :mod:`bodyvib.vehicle.sweep.engines`).

No time history is written (unless asked for), so nothing is read back. The cases are
laid out side by side in lanes, up to :data:`LANES` at a time: the inner loop runs
over the lanes with the same operation for each, which the compiler turns into vector
instructions. Each lane does its own case's arithmetic in a fixed
order (numba without fast-math: no reassociation, no contraction), so a case's results
are the same bits whatever other cases share its lanes or its task.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["LANES", "SUMS", "WK_STATES", "KernelInputs", "pack", "run"]

#: Most cases stepped side by side: wide enough that the compiler's vector loops over
#: the lanes run many iterations, small enough that a chunk's matrices stay in cache
#: (per case-step on 512 cases: 47 ns at 64 lanes, 43-45 at 128, 49-53 at 256).
LANES = 128
#: The rows of the running sums :func:`run` returns per case.
SUMS = (
    "head_s2",
    "head_s4",
    "head_peak",
    "head_window_max",
    "seat_s2",
    "seat_s4",
    "seat_peak",
    "seat_window_max",
    "force0_peak",
    "force1_peak",
    "check",
)

#: The weighting's states in the loop: the ISO 2631-1 Wk filter's four sections of two
#: states in series, row ``r`` of the step reading the states of sections ``0 .. r // 2``.
#: A smaller weighting of that shape runs padded with zeros.
WK_STATES = 8

_compiled = None


def _functions():
    """The compiled pieces: ``(step, weigh, kernel)`` (compiled on first use, cached)."""
    global _compiled
    if _compiled is not None:
        return _compiled
    from numba import njit

    @njit(inline="always")
    def step(M, gz, gv, road, z, v, ch, k, x, out, zk, vk):  # pragma: no cover (compiled)
        """Chunk ``ch``'s exact step at sample ``k``: ``out = M x + sum_p (g_z z + g_v v)_p``,
        then ``x = out[:n]``; every innermost loop over the lanes."""
        _, m, n, L = M.shape
        P = gz.shape[1]
        for p in range(P):
            for i in range(L):
                zk[p, i] = z[k, road[ch, p, i]]
                vk[p, i] = v[k, road[ch, p, i]]
        for r in range(m):
            o = out[r]
            for i in range(L):
                o[i] = 0.0
            for q in range(n):
                Mq = M[ch, r, q]
                xq = x[q]
                for i in range(L):
                    o[i] += Mq[i] * xq[i]
            for p in range(P):
                gzr = gz[ch, p, r]
                gvr = gv[ch, p, r]
                for i in range(L):
                    o[i] = o[i] + (gzr[i] * zk[p, i] + gvr[i] * vk[p, i])
        for q in range(n):
            for i in range(L):
                x[q, i] = out[q, i]

    @njit(inline="always")
    def dot(p, s):  # pragma: no cover (compiled)
        """``p[0] s[0] + p[1] s[1] + ..`` over ``p``'s entries, summed left to right."""
        acc = p[0] * s[0]
        for j in range(1, len(p)):
            acc += p[j] * s[j]
        return acc

    @njit(inline="always")
    def six(ph, gp, gn, s, u, a):  # pragma: no cover (compiled)
        """The weighting's first six states after the step from ``s`` (the states before
        it), the sample ``u`` to ``a``; rows ``0 .. 5`` read at most six states."""
        n0 = dot(ph[0], s) + (gp[0] * u + gn[0] * a)
        n1 = dot(ph[1], s) + (gp[1] * u + gn[1] * a)
        n2 = dot(ph[2], s) + (gp[2] * u + gn[2] * a)
        n3 = dot(ph[3], s) + (gp[3] * u + gn[3] * a)
        n4 = dot(ph[4], s) + (gp[4] * u + gn[4] * a)
        n5 = dot(ph[5], s) + (gp[5] * u + gn[5] * a)
        return (n0, n1, n2, n3, n4, n5)

    @njit(inline="always")
    def weigh(xs, i, w, u, a):  # pragma: no cover (compiled)
        """Lane ``i``'s weighting states ``xs[:, i]`` advanced from sample ``u`` to ``a``
        (``w``: the step's rows, ``g_prev``, ``g_next``, then ``c``, ``d``); the weighted
        sample. The states are read once into registers and written once."""
        (ph, gp, gn), c, d = w
        s = (xs[0, i], xs[1, i], xs[2, i], xs[3, i], xs[4, i], xs[5, i], xs[6, i], xs[7, i])
        n = six(ph, gp, gn, s, u, a) + (
            dot(ph[6], s) + (gp[6] * u + gn[6] * a),
            dot(ph[7], s) + (gp[7] * u + gn[7] * a),
        )
        for j in range(8):
            xs[j, i] = n[j]
        return dot(c, n) + d * a

    @njit(inline="always")
    def weigh6(xs, i, w, u, a):  # pragma: no cover (compiled)
        """``weigh`` of a weighting whose output reads its first six states only
        (``w`` of six entries: ``_weighting`` with ``states=6``): the states after
        them, which nothing read, are not stepped."""
        (ph, gp, gn), c, d = w
        s = (xs[0, i], xs[1, i], xs[2, i], xs[3, i], xs[4, i], xs[5, i])
        n = six(ph, gp, gn, s, u, a)
        for j in range(6):
            xs[j, i] = n[j]
        return dot(c, n) + d * a

    @njit(cache=True, nogil=True, boundscheck=False)
    def kernel(M, gz, gv, road, z, v, wk, A, axes, window, sums, hist):
        # pragma: no cover (compiled)
        # every innermost loop runs over the L lanes: the same operation for each case
        chunks, m, n, L = M.shape
        P = gz.shape[1]
        N = z.shape[0]
        record = hist.shape[3] > 0
        watched = m - n - 4 - A
        x = np.empty((n, L))
        out = np.empty((m, L))
        zk = np.empty((P, L))
        vk = np.empty((P, L))
        # The weighting's per-lane rows of every channel in one block, each row LANES
        # long (a constant), not L: the compiler then knows any two rows a fixed
        # distance apart and vectorizes the weighting's lane loop as it is. Rows of L
        # lanes are an unknown distance apart, and the loop would first check every
        # pair of them for overlap, at every sample (more time than its arithmetic).
        # Channels: head and seat (Wk), then x and y with each weighting of ``axes``.
        C = 2 + 2 * A
        rows = np.empty((C, WK_STATES + 6, LANES))
        xw = rows[:, :WK_STATES]  # the filter's states
        aprev = rows[:, WK_STATES]  # the previous sample's acceleration
        total = rows[:, WK_STATES + 1]  # the running window's sum of a_w^2
        wsum = rows[:, WK_STATES + 2 :]  # sum a_w^2, sum a_w^4, max |a_w|, window max
        ring = np.empty((2, window, L))
        # the force peaks, the check sum and the watched rows' maxima, the same way
        fsum = np.empty((3 + watched, LANES))
        for ch in range(chunks):
            rows[:] = 0.0
            x[:] = 0.0
            ring[:] = 0.0
            fsum[:] = 0.0
            pos = 0
            for k in range(N):
                step(M, gz, gv, road, z, v, ch, k, x, out, zk, vk)
                y = out[n:]  # the outputs: head, seat, the forces, watched, x and y
                # the forces: largest magnitude; a non-finite value spoils the check sum
                for f in range(2):
                    for i in range(L):
                        yf = abs(y[2 + f, i])
                        fsum[2, i] += yf * 0.0
                        fsum[f, i] = yf if yf > fsum[f, i] else fsum[f, i]
                # the watched rows (a nonlinear car's switching margins): largest value
                for f in range(watched):
                    for i in range(L):
                        yf = y[4 + f, i]
                        fsum[2, i] += yf * 0.0
                        fsum[3 + f, i] = yf if yf > fsum[3 + f, i] else fsum[3 + f, i]
                # Wk of head (s = 0) and seat (s = 1), then the figures' sums.
                # The first sample starts the filter from rest: a step of zeros
                first = k == 0
                w = (wk[1] if first else wk[0], wk[2], wk[3])
                for s in range(2):
                    xs = xw[s]
                    for i in range(L):
                        a = y[s, i]
                        wi = weigh(xs, i, w, aprev[s, i], a)
                        aprev[s, i] = a
                        w2 = wi * wi
                        wsum[s, 0, i] += w2
                        wsum[s, 1, i] += w2 * w2
                        aw = abs(wi)
                        wsum[s, 2, i] = aw if aw > wsum[s, 2, i] else wsum[s, 2, i]
                        t = total[s, i] + (w2 - ring[s, pos, i])
                        total[s, i] = t
                        ring[s, pos, i] = w2
                        wsum[s, 3, i] = t if t > wsum[s, 3, i] else wsum[s, 3, i]
                # the seat's x and y with each weighting of ``axes``: sum a_w^2 only,
                # the four in one pass over the lanes
                if A:
                    d, e = axes
                    wd = (d[1] if first else d[0], d[2], d[3])
                    we = (e[1] if first else e[0], e[2], e[3])
                    yx, yy = y[4 + watched], y[5 + watched]
                    xdx, xdy, xex, xey = xw[2], xw[3], xw[4], xw[5]
                    for i in range(L):
                        ax = yx[i]
                        ay = yy[i]
                        ux = aprev[2, i]
                        uy = aprev[3, i]
                        aprev[2, i] = ax
                        aprev[3, i] = ay
                        w0 = weigh6(xdx, i, wd, ux, ax)
                        w1 = weigh6(xdy, i, wd, uy, ay)
                        w2 = weigh6(xex, i, we, ux, ax)
                        w3 = weigh6(xey, i, we, uy, ay)
                        wsum[2, 0, i] += w0 * w0
                        wsum[3, 0, i] += w1 * w1
                        wsum[4, 0, i] += w2 * w2
                        wsum[5, 0, i] += w3 * w3
                if record:
                    for s in range(2):
                        for i in range(L):
                            hist[ch, s, i, k] = y[s, i]
                pos += 1
                if pos == window:  # a fresh sum of the ring: no rounding carried along
                    pos = 0
                    for s in range(2):
                        for i in range(L):
                            total[s, i] = 0.0
                        for j in range(window):
                            for i in range(L):
                                total[s, i] += ring[s, j, i]
            # in the order of SUMS: head, seat, forces and check, watched; then x and y
            for s in range(2):
                for j in range(4):
                    for i in range(L):
                        sums[ch, 4 * s + j, i] = wsum[s, j, i]
            for r in range(3 + watched):
                for i in range(L):
                    sums[ch, 8 + r, i] = fsum[r, i]
            for s in range(2, C):
                for i in range(L):
                    sums[ch, 9 + watched + s, i] = wsum[s, 0, i]

    _compiled = (step, weigh, kernel)
    return _compiled


@dataclass(frozen=True)
class KernelInputs:
    """A group's matrices and road rows laid out in lanes for :func:`run` (:func:`pack`).

    Attributes
    ----------
    M : (chunks, n + 4 + watched rows (+ 2), n, lanes) ndarray
        ``[Phi; C_out]``; the outputs head, seat, the two forces, the watched rows
        and, with the weightings of :func:`run`'s ``axes``, the seat's x and y.
    gz, gv : (chunks, points, rows of M, lanes) ndarray
    road : (chunks, points, lanes) ndarray of int
    cases : int
        The cases in the lanes, in order; the lanes after the last are zero (their
        outputs are discarded).
    """

    M: np.ndarray
    gz: np.ndarray
    gv: np.ndarray
    road: np.ndarray
    cases: int


def pack(M, gz, gv, road) -> KernelInputs:
    """Lay out per-case step matrices in chunks of at most :data:`LANES` cases.

    The chunks are of equal width (the last one padded with zero cases).

    Parameters
    ----------
    M : (cases, rows, n) ndarray
        ``[Phi; C_out]`` of each case (the output rows of :class:`KernelInputs`).
    gz, gv : (cases, points, rows) ndarray
        Input columns of each road point's displacement and velocity (with the
        in-step slope).
    road : (cases, points) ndarray of int
        The row of the road arrays each road point of a case drives on.

    Returns
    -------
    KernelInputs

    Examples
    --------
    >>> k = pack(np.zeros((300, 5, 1)), np.zeros((300, 1, 5)), np.zeros((300, 1, 5)),
    ...          np.zeros((300, 1), int))
    >>> k.M.shape, k.cases
    ((3, 5, 1, 100), 300)
    """
    c = M.shape[0]
    chunks = -(-c // LANES)
    width = -(-c // chunks)
    pad = chunks * width - c

    def lanes(a):
        a = np.concatenate([a, np.zeros((pad,) + a.shape[1:], a.dtype)])
        a = a.reshape((chunks, width) + a.shape[1:])
        return np.ascontiguousarray(np.moveaxis(a, 1, -1))

    return KernelInputs(lanes(M), lanes(gz), lanes(gv), lanes(np.asarray(road, np.int64)), c)


def _padded(a) -> tuple:
    """``a`` as a tuple of :data:`WK_STATES` floats, zeros after its entries."""
    return tuple(float(e) for e in np.concatenate([a, np.zeros(WK_STATES - len(a))]))


def _sections(wk, rest: bool = False) -> tuple:
    """The weighting's step as the loop reads it: ``(rows of Phi, g_prev, g_next)``.

    Row ``r`` of ``Phi`` becomes a tuple of its first ``2 (r // 2 + 1)`` entries,
    those at and past ``wk.reads[r]`` set to zero (the loop adds their zero products,
    which leaves every sum as it is); ``g_prev`` and ``g_next`` are padded with zeros
    to :data:`WK_STATES` entries. With ``rest``, the same shapes all zero: the step
    that keeps the filter at rest over the first sample.
    """
    n = wk.Phi.shape[0]
    reads = np.asarray(wk.reads, np.int64)
    width = 2 * (np.arange(WK_STATES) // 2 + 1)
    if n > WK_STATES or np.any(reads > width[:n]):
        raise ValueError(
            f"the weighting does not fit the loop: at most {WK_STATES} states, row r "
            f"reading at most 2 (r // 2 + 1) of them; got reads {reads.tolist()}"
        )
    Phi = np.zeros((WK_STATES, WK_STATES))
    if not rest:
        for r in range(n):
            Phi[r, : reads[r]] = wk.Phi[r, : reads[r]]
    rows = tuple(tuple(float(e) for e in Phi[r, : width[r]]) for r in range(WK_STATES))
    zero = np.zeros(n)
    return (
        rows,
        _padded(zero if rest else wk.g_prev),
        _padded(zero if rest else wk.g_next),
    )


def _weighting(wk, states: int = WK_STATES) -> tuple:
    """The weighting as the loop reads it: ``(step, step from rest, c, d)``, ``c``
    padded to :data:`WK_STATES` entries; of its first ``states`` states only."""
    step, rest = (tuple(t[:states] for t in _sections(wk, rest=r)) for r in (False, True))
    return (step, rest, _padded(np.asarray(wk.c, float))[:states], float(wk.d))


def _axis_weighting(wk) -> tuple:
    """:func:`_weighting` of one of :func:`run`'s ``axes``: its first six states, the
    only ones its output may read."""
    if np.any(np.asarray(wk.c, float)[6:] != 0):
        raise ValueError("a weighting of the seat's x and y reads its first six states only")
    return _weighting(wk, 6)


def run(inputs: KernelInputs, z, v, wk, window: int, record: bool = False, axes=None):
    """Step every case over all samples; the running sums (and histories).

    Parameters
    ----------
    inputs : KernelInputs
        From :func:`pack`: at most :data:`LANES` lanes.
    z, v : (roads, samples) ndarray
        Road displacement (m) and velocity (m/s) at every sample.
    wk : bodyvib.comfort.stream.WeightingStep
        The discretized Wk weighting (:meth:`bodyvib.comfort.stream.WkFilter.step`);
        row ``r`` of its step reads the first ``reads[r]`` states. At most
        :data:`WK_STATES` states, row ``r`` reading at most ``2 (r // 2 + 1)``.
    window : int
        Samples of the MTVV's running window.
    record : bool
        Also return the head and seat acceleration histories.
    axes : (WeightingStep, WeightingStep), optional
        Two more weightings (of the shape of ``wk``'s) of ``M``'s last two rows, the
        seat's x and y acceleration, in the same pass: each row's ``sum a_w^2`` with each.
        Their output reads their first six states only (Wd and We: the last section's
        states, of a step factor with ``f5 = inf``, are not read), and only those are
        stepped.

    Returns
    -------
    sums : (len(SUMS) + watched rows (+ 4), cases) ndarray
        :data:`SUMS` of each case: ``sum a_w^2``, ``sum a_w^4``, ``max |a_w|``
        and the largest ``window``-sample sum of ``a_w^2`` of the head and the
        seat, the two force peaks, a check sum that is 0 unless a force
        was not finite, then the largest value of each watched row (``M``'s rows
        after ``n + 4``, before the seat's x and y; the check sum covers them too);
        with ``axes``, then ``sum a_w^2`` of x and y with ``axes[0]``, then with ``axes[1]``.
    histories : (2, cases, samples) ndarray or None
        Head and seat acceleration, m/s2, with ``record``.

    Raises
    ------
    ValueError
        A packing wider than :data:`LANES` lanes, or a weighting that does not fit
        (of ``axes``: whose output reads a state past the sixth).

    Examples
    --------
    One state that halves each step, kicked by a unit road at the first sample,
    its output the head acceleration; a weighting that passes the signal through:

    >>> M = np.array([[[0.5], [1.0], [0.0], [0.0], [0.0]]])
    >>> g1 = np.array([[[1.0, 0, 0, 0, 0]]]); g0 = np.zeros((1, 1, 5))
    >>> z = np.array([[1.0, 0, 0, 0]]); v = np.zeros((1, 4))
    >>> from bodyvib.comfort.stream import WeightingStep
    >>> wk = WeightingStep(np.zeros((1, 1)), np.zeros(1), np.zeros(1), np.zeros(1), 1.0, [1])
    >>> sums, h = run(pack(M, g1, g0, np.zeros((1, 1), int)), z, v, wk, 2, record=True)
    >>> h[0, 0].tolist(), float(sums[0, 0]), float(sums[3, 0])
    ([0.0, 1.0, 0.5, 0.25], 1.3125, 1.25)
    """
    chunks, width = inputs.M.shape[0], inputs.M.shape[3]
    if width > LANES:  # the loop's rows of the weighting hold LANES lanes
        raise ValueError(f"at most {LANES} lanes, got {width}")
    N = z.shape[1]
    A = 0 if axes is None else 2
    rows = len(SUMS) + inputs.M.shape[1] - inputs.M.shape[2] - 4 + A  # watched, x and y
    sums = np.empty((chunks, rows, width))
    hist = np.empty((chunks, 2, width, N if record else 0))
    weighting = _weighting(wk)
    _functions()[2](
        inputs.M,
        inputs.gz,
        inputs.gv,
        inputs.road,
        # a sample of every road in one row: the lanes read them together
        np.ascontiguousarray(np.transpose(z), float),
        np.ascontiguousarray(np.transpose(v), float),
        weighting,
        A,
        (_weighting(wk, 6),) * 2 if axes is None else tuple(_axis_weighting(w) for w in axes),
        int(window),
        sums,
        hist,
    )
    c = inputs.cases
    sums = np.moveaxis(sums, 2, 1).reshape(chunks * width, rows)[:c].T
    if not record:
        return sums, None
    return sums, np.moveaxis(hist, 1, 0).reshape(2, chunks * width, N)[:, :c]
