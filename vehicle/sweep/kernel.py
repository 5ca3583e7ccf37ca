"""The batched engine's time loop, compiled: exact step, Wk weighting and figure sums in one pass.

For every case of a group and every sample ``k`` the loop computes

* the exact step of the seated system and its outputs,
  ``[x_{k+1}; y_k] = M x_k + g_z z_k + g_v v_k``, ``M = [Phi; C_out]``
  (``(n + 4) x n``); the outputs are the head and seat acceleration and the neck
  and lumbar forces. A car driven at several road points (the wheels of a half car)
  is linear: each point drives its own copy of the state through its own input
  columns, and the outputs are the sum of the points' responses;
* the ISO 2631-1 Wk weighting of the head and the seat acceleration, the analog
  filter advanced exactly over the straight line between two samples
  (:class:`bodyvib.comfort.stream.WkFilter`'s recursion, evaluated sample by sample);
* the running sums the figures come from: ``sum a_w^2``, ``sum a_w^4``,
  ``max |a_w|``, the largest 1 s sum of ``a_w^2`` (the MTVV), and the largest
  ``|force|``.

No time history is written (unless asked for), so nothing is read back. The cases are
laid out side by side in lanes, up to :data:`LANES` at a time: the inner loop runs
over the lanes with the same operation for each, which the compiler turns into vector
instructions. Each lane does its own case's arithmetic in a fixed
order (numba without fast-math: no reassociation, no contraction), so a case's results
are the same bits whatever other cases share its lanes or its task.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["LANES", "SUMS", "KernelInputs", "pack", "run"]

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

_compiled = None


def _kernel():
    global _compiled
    if _compiled is not None:
        return _compiled
    from numba import njit

    @njit(cache=True, nogil=True, boundscheck=False)
    def kernel(M, gz, gv, road, z, v, wphi, wreads, wgp, wgn, wc, wd, window, sums, hist):
        # pragma: no cover (compiled)
        # every innermost loop runs over the L lanes: the same operation for each case
        chunks, m, n, L = M.shape
        P = gz.shape[1]
        nw = wphi.shape[0]
        N = z.shape[0]
        record = hist.shape[3] > 0
        x = np.empty((P, n, L))
        out = np.empty((m, L))
        y = np.empty((m - n, L))
        zk = np.empty((P, L))
        vk = np.empty((P, L))
        xw = np.empty((2, nw, L))
        xn = np.empty((nw, L))
        aprev = np.empty((2, L))
        w = np.empty(L)
        ring = np.empty((2, window, L))
        total = np.empty((2, L))
        acc = np.empty((11, L))
        for ch in range(chunks):
            x[:] = 0.0
            xw[:] = 0.0
            ring[:] = 0.0
            total[:] = 0.0
            acc[:] = 0.0
            pos = 0
            for k in range(N):
                for p in range(P):
                    for i in range(L):
                        zk[p, i] = z[k, road[ch, p, i]]
                        vk[p, i] = v[k, road[ch, p, i]]
                # the exact step, one state per road point: C x + (g_z z + g_v v)
                for p in range(P):
                    for r in range(m):
                        o = out[r]
                        for i in range(L):
                            o[i] = 0.0
                        for q in range(n):
                            Mq = M[ch, r, q]
                            xq = x[p, q]
                            for i in range(L):
                                o[i] += Mq[i] * xq[i]
                        gzr = gz[ch, p, r]
                        gvr = gv[ch, p, r]
                        for i in range(L):
                            o[i] = o[i] + (gzr[i] * zk[p, i] + gvr[i] * vk[p, i])
                    for q in range(n):
                        for i in range(L):
                            x[p, q, i] = out[q, i]
                    # the outputs: the sum of the road points' responses (the car is linear)
                    if p == 0:
                        for r in range(m - n):
                            for i in range(L):
                                y[r, i] = out[n + r, i]
                    else:
                        for r in range(m - n):
                            for i in range(L):
                                y[r, i] += out[n + r, i]
                # the forces: largest magnitude; a non-finite value spoils the check sum
                for f in range(m - n - 2):
                    for i in range(L):
                        yf = abs(y[2 + f, i])
                        acc[10, i] += yf * 0.0
                        acc[8 + f, i] = yf if yf > acc[8 + f, i] else acc[8 + f, i]
                # Wk of head (s = 0) and seat (s = 1), then the figures' sums
                for s in range(2):
                    if k > 0:
                        for r in range(nw):
                            o = xn[r]
                            for i in range(L):
                                o[i] = 0.0
                            for q in range(wreads[r]):
                                c = wphi[r, q]
                                for i in range(L):
                                    o[i] += c * xw[s, q, i]
                            for i in range(L):
                                o[i] = o[i] + (wgp[r] * aprev[s, i] + wgn[r] * y[s, i])
                        for r in range(nw):
                            for i in range(L):
                                xw[s, r, i] = xn[r, i]
                    for i in range(L):
                        w[i] = 0.0
                    for q in range(nw):
                        c = wc[q]
                        if c == 0.0:  # the output row reads the last section only
                            continue
                        for i in range(L):
                            w[i] += c * xw[s, q, i]
                    b = 4 * s
                    for i in range(L):
                        a = y[s, i]
                        aprev[s, i] = a
                        wi = w[i] + wd * a
                        w2 = wi * wi
                        acc[b, i] += w2
                        acc[b + 1, i] += w2 * w2
                        aw = abs(wi)
                        acc[b + 2, i] = aw if aw > acc[b + 2, i] else acc[b + 2, i]
                        t = total[s, i] + (w2 - ring[s, pos, i])
                        total[s, i] = t
                        ring[s, pos, i] = w2
                        acc[b + 3, i] = t if t > acc[b + 3, i] else acc[b + 3, i]
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
            for r in range(11):
                for i in range(L):
                    sums[ch, r, i] = acc[r, i]

    _compiled = kernel
    return kernel


@dataclass(frozen=True)
class KernelInputs:
    """A group's matrices and road rows laid out in lanes for :func:`run` (:func:`pack`).

    Attributes
    ----------
    M : (chunks, n + 4, n, lanes) ndarray
    gz, gv : (chunks, points, n + 4, lanes) ndarray
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
    M : (cases, n + 4, n) ndarray
        ``[Phi; C_out]`` of each case.
    gz, gv : (cases, points, n + 4) ndarray
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


def run(inputs: KernelInputs, z, v, wk, window: int, record: bool = False):
    """Step every case over all samples; the running sums (and histories).

    Parameters
    ----------
    inputs : KernelInputs
        From :func:`pack`.
    z, v : (roads, samples) ndarray
        Road displacement (m) and velocity (m/s) at every sample.
    wk : bodyvib.comfort.stream.WeightingStep
        The discretized Wk weighting (:meth:`bodyvib.comfort.stream.WkFilter.step`);
        row ``r`` of its step reads the first ``reads[r]`` states.
    window : int
        Samples of the MTVV's running window.
    record : bool
        Also return the head and seat acceleration histories.

    Returns
    -------
    sums : (len(SUMS), cases) ndarray
        :data:`SUMS` of each case: ``sum a_w^2``, ``sum a_w^4``, ``max |a_w|``
        and the largest ``window``-sample sum of ``a_w^2`` of the head and the
        seat, the two force peaks, and a check sum that is 0 unless a force
        was not finite.
    histories : (2, cases, samples) ndarray or None
        Head and seat acceleration, m/s2, with ``record``.

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
    N = z.shape[1]
    sums = np.empty((chunks, len(SUMS), width))
    hist = np.empty((chunks, 2, width, N if record else 0))
    _kernel()(
        inputs.M,
        inputs.gz,
        inputs.gv,
        inputs.road,
        # a sample of every road in one row: the lanes read them together
        np.ascontiguousarray(np.transpose(z), float),
        np.ascontiguousarray(np.transpose(v), float),
        np.ascontiguousarray(wk.Phi, float),
        np.asarray(wk.reads, np.int64),
        np.ascontiguousarray(wk.g_prev, float),
        np.ascontiguousarray(wk.g_next, float),
        np.ascontiguousarray(wk.c, float),
        float(wk.d),
        int(window),
        sums,
        hist,
    )
    c = inputs.cases
    sums = np.moveaxis(sums, 2, 1).reshape(chunks * width, len(SUMS))[:c].T
    if not record:
        return sums, None
    return sums, np.moveaxis(hist, 1, 0).reshape(2, chunks * width, N)[:, :c]
