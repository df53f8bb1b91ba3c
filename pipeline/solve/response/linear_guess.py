"""The first guess of a forced response: the linear solutions with the contacts open
and fully stuck, the one nearer the nonlinear equations taken."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..harmonic_balance import hbm


def initial_guess(prob, Om, contact):
    """Starting vector x of the condensed HBM problem `prob` at Om [rad/s]: of the
    linear solutions with the contacts open and fully stuck, the one with the smaller
    nonlinear residual (`hbm.residual` with the elements `contact`; `response.GUESS_NFEV`
    evaluations).  A problem with a sparse Jacobian (a wheel) solves them sparse, on
    its pattern."""
    nh, nc, pat = prob.nh, prob.c.size, prob.pattern
    St, _, Pt, _ = hbm.linear_part(prob, Om, derivatives=False, pattern=pat)
    # linearised contact stiffness: ku along t, kv along n (assembled)
    bt, bn, idx = prob.bt, prob.bn, prob.idx
    blocks = (contact.ku[:, None, None] * bt[:, :, None] * bt[:, None, :]
              + contact.kv[:, None, None] * bn[:, :, None] * bn[:, None, :])
    rows = np.broadcast_to(idx[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(idx[:, None, :], blocks.shape).ravel()
    Kc = sp.csr_matrix((blocks.ravel(), (rows, cols)), shape=(nc, nc))
    guesses = []
    for stuck in (False, True):
        xs = []
        for h in range(prob.H + 1):
            if pat is not None:
                A = sp.csc_matrix((St[h], (pat.pi, pat.pj)), shape=(nc, nc)) + stuck * Kc
                xs.append(_sparse_solve(A.tocsc(), Pt[h]))
                continue
            A = St[h] + Kc.toarray() if stuck else St[h]
            try:
                xs.append(np.linalg.solve(A, Pt[h]))
            except np.linalg.LinAlgError:
                xs.append(np.linalg.lstsq(A, Pt[h], rcond=None)[0])
        guesses.append(hbm.real_vector(np.array(xs), nh).ravel())
    norms = [np.linalg.norm(hbm.residual(prob, g, Om, contact, jacobian=False)[0]) for g in guesses]
    return guesses[int(np.argmin(norms))]


def _sparse_solve(A, b):
    """A^-1 b by a sparse LU, or its least-squares solution if A is singular."""
    try:
        return spla.splu(A).solve(b)
    except RuntimeError:
        return spla.lsqr(A, b)[0]
