"""The harmonic dynamic stiffness of the linear structure (paper Eq. 7) and its
condensation onto the contact DOFs: the one place where M and C meet a frequency.

Per harmonic h, at w = h Omega and for the complex amplitude Q_h = Qc_h - i Qs_h,

    S_h(Omega) = K_h - w^2 M + i w C + sum_t a_t(w) A_t,
    dS_h/dOmega = h (-2 w M + i C) + sum_t da_t/dOmega A_t,

K_h the stiffness of harmonic h (K, or for a cyclic sector with a linear inter-sector
coupling K + e^{i h phi} K_next + e^{-i h phi} K_next^T, `stiffness_stack`); a sector
cut out of a flexible disk couples its mass and damping too, so M and C are per
harmonic there (M_h, C_h in the same way, `harmonic_matrices`; strategy "dense").  An added
linear term t is one `Term` (A_t, p_t, imag_t, q_t), a_t = w^p Omega^q (times i if
imag): a mass-proportional damping c' M q' is Term(c' M, 1, True), exactly C + c' M;
a gyroscopic G q' is Term(G, 1, True); the damping -2 zeta Omega M q' of the extended
periodic motion concept (nonlinear modes) is Term(-2 zeta M, 1, True, 1).  Terms act
on the harmonics h >= 1 only (p >= 1).  The derivative with respect to a parameter on
which the matrices A_t depend (zeta) is the same sum over the terms
(dA_t/dp, p_t, imag_t, q_t) (`term_stiffness`).

Condensation: the contact DOFs c keep their unknowns, the others o are eliminated,

    S~ = S_cc - S_co X,  X = S_oo^-1 S_oc,   P~ = P_c - S_co S_oo^-1 P_o,
    dS~ = dS_cc - dS_co X - Y dS_oc + Y dS_oo X,  Y = S_co S_oo^-1,
    dP~ = -dS_co z + Y dS_oo z,  z = S_oo^-1 P_o,

and `recover` gives Q_o = S_oo^-1 (P_o - S_oc Q_c).  How S is formed and condensed is
decided once per problem (`prepare`), by the storage of the matrices:

    "blocks"  dense, interior DOFs: K, M, C blocks over (c, o) gathered once; their
              S and dS formed here and passed to the algebra of `interior`
    "dense"   dense otherwise (every DOF a contact DOF, or a K_next coupling)
    "parts"   sparse, the interior falls into equal independent parts (`parts`)
    "sparse"  sparse otherwise: one sparse LU per harmonic, the blocks of K, M, C
              cut once (`sparse_blocks`).

The operators of all DOFs in the real layout (Hill's method, the full residual) are
`full_operator` and `apply_full`: K (x) I + Om C (x) D + Om^2 M (x) D^2.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ...fourier.harmonics import complex_harmonics, derivative_matrix
from ...fourier.harmonics import shift as time_shift
from ...model.system import coupled_matrix, coupled_stiffness, coupling, dense, inertia_coupled
from .interior import condense_blocks, interior_blocks
from .parts import PartBlocks, applied, on_contact_dofs, on_parts, on_pattern, part_blocks
from .sparse_blocks import SparseBlocks, sparse_blocks


@dataclass(frozen=True, eq=False)
class Term:
    """An added linear term a A of the dynamic stiffness, a = w^power Omega^omega_power
    (times i if imag), w = h Omega: Omega^q A d^p q/dt^p is Term(A (-1)^(p//2), p, p odd,
    q)."""

    matrix: object        # (n, n), dense or scipy.sparse, as the system's matrices
    power: int            # power of w = h Omega (>= 1)
    imag: bool = False    # multiplied by i
    omega_power: int = 0  # power of Omega itself (a matrix proportional to Omega^q)

    def __post_init__(self):
        if int(self.power) < 1:
            raise ValueError(f"a term's power of h Omega must be >= 1, got {self.power}")

    def factor(self, w, Om):
        """a at w = h Omega."""
        a = w ** self.power
        if self.omega_power:
            a = a * Om ** self.omega_power
        return 1j * a if self.imag else a

    def rate(self, h, w, Om):
        """da/dOmega = h p w^(p-1) Omega^q + q w^p Omega^(q-1) (times i)."""
        p, q = self.power, self.omega_power
        a = h * p * w ** (p - 1)
        if q:
            a = a * Om ** q + q * w ** p * Om ** (q - 1)
        return 1j * a if self.imag else a


STRATEGIES = ("blocks", "dense", "parts", "sparse")


@dataclass(frozen=True, eq=False)
class DynamicStiffness:
    """The linear part of a problem with H harmonics, split into contact DOFs c and
    eliminated DOFs o, its strategy (module doc) fixed by `prepare`."""

    strategy: str
    H: int
    c: np.ndarray
    o: np.ndarray
    M: object              # mass [kg], dense float or sparse as given
    C: object              # damping [N s/m]
    K: object              # stiffness of each harmonic: (H+1, n, n) dense, or a tuple
    loads: np.ndarray      # (H+1, n) complex load of each harmonic [N]
    extra: tuple = ()      # added `Term`s
    blocks: object = None  # interior.InteriorBlocks, parts.PartBlocks or sparse_blocks.SparseBlocks

    @property
    def parts(self) -> PartBlocks | None:
        return self.blocks if self.strategy == "parts" else None


def harmonic_stiffnesses(sys, H: int) -> list:
    """Stiffness K_h of each harmonic h = 0..H (storage as given): K, or for a cyclic
    sector with a linear inter-sector coupling K + e^{i h phi} K_next + e^{-i h phi} K_next^T."""
    phi = sys.cyclic.phase if sys.cyclic is not None else 0.0
    return [coupled_stiffness(sys, h * phi) for h in range(H + 1)]


def harmonic_matrices(sys, name: str, H: int) -> np.ndarray:
    """(H+1, n, n) dense M_h or C_h (`name` "M" or "C") of each harmonic of a cyclic
    sector with a mass coupling: X + e^{i h phi} X_next + e^{-i h phi} X_next^T."""
    phi = sys.cyclic.phase
    return np.stack([np.asarray(dense(coupled_matrix(sys, name, h * phi)), complex)
                     for h in range(H + 1)])


def stiffness_stack(sys, H: int) -> np.ndarray:
    """(H+1, n, n) `harmonic_stiffnesses`, dense."""
    return np.stack([dense(K) for K in harmonic_stiffnesses(sys, H)])


def prepare(sys, H: int, c, o, P, extra=(), strategy: str | None = None) -> DynamicStiffness:
    """The `DynamicStiffness` of a system (its load P (n, 2H+1) [N]), the strategy
    chosen from the matrices' storage (module doc) unless given."""
    if strategy is not None and strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    extra, chosen = tuple(extra), strategy
    if inertia_coupled(sys):
        if strategy not in (None, "dense"):
            raise ValueError(f"strategy {strategy!r} does not apply to a sector whose mass "
                             "couples it to its neighbours (a flexible disk): 'dense'")
        strategy = "dense"
    if strategy is None:
        coupled = sys.cyclic is not None and sys.cyclic.K_next is not None
        strategy = (("sparse" if sys.cyclic is not None else "parts") if sp.issparse(sys.K)
                    else ("dense" if coupled else "blocks"))
    xs, blocks = [t.matrix for t in extra], None
    if strategy == "blocks":
        blocks = interior_blocks(*(dense(A) for A in (sys.K, sys.M, sys.C)), c, o,
                                 [dense(A) for A in xs])
    elif strategy == "parts":
        blocks = part_blocks(sys, c, o, xs)
    if blocks is None and strategy in ("blocks", "parts"):
        if chosen is not None:
            raise ValueError(f"strategy {strategy!r} does not apply (no interior or no parts)")
        strategy = "dense" if strategy == "blocks" else "sparse"
    if strategy in ("blocks", "dense"):
        M, C = ((harmonic_matrices(sys, name, H) for name in ("M", "C")) if inertia_coupled(sys)
                else (np.asarray(dense(A), dtype=float) for A in (sys.M, sys.C)))
        K = stiffness_stack(sys, H)
        extra = tuple(replace(t, matrix=np.asarray(dense(t.matrix), dtype=float))
                      for t in extra)
    else:
        M, C, K = sys.M, sys.C, tuple(harmonic_stiffnesses(sys, H))
        blocks = sparse_blocks(K, M, C, xs, c, o) if strategy == "sparse" else blocks
    return DynamicStiffness(strategy, int(H), c, o, M, C, K, complex_harmonics(P), extra,
                            blocks)


# ---- S and dS/dOmega, as each strategy forms them

def at_harmonic(K, M, C, h, Om: float, added=()):
    """S_h = K - (h Om)^2 M + i h Om C + sum a_t A_t, `added` the pairs (A_t, a_t);
    h an int or an array broadcasting against the matrices (dense or sparse)."""
    S = K - (h * Om) ** 2 * M + 1j * h * Om * C
    for A, a in added:
        S = S + a * A
    return S


def harmonic_rate(M, C, h, Om: float, added=()):
    """dS_h/dOmega = -2 h^2 Om M + i h C + sum da_t/dOmega A_t, `added` the pairs
    (A_t, da_t/dOmega) (`at_harmonic`)."""
    dS = -2 * h * h * Om * M + 1j * h * C
    for A, a in added:
        dS = dS + a * A
    return dS


def at_frequency(K, M, C, w: float, added=()):
    """S = K - w^2 M + i w C + sum a_t A_t at one circular frequency w = h Omega,
    `added` the pairs (A_t, a_t)."""
    S = K - w * w * M + 1j * w * C
    for A, a in added:
        S = S + a * A
    return S


def _pairs(extra, h, Om, rate=False, matrices=None):
    """(A_t, a_t) (or (A_t, da_t/dOmega)) of the terms at harmonic(s) h."""
    mats = [t.matrix for t in extra] if matrices is None else matrices
    return [(A, t.rate(h, h * Om, Om) if rate else t.factor(h * Om, Om))
            for A, t in zip(mats, extra)]


def dense_stack(ds: DynamicStiffness, Om: float) -> np.ndarray:
    """(H+1, n, n) S_h of the dense strategies."""
    h = np.arange(ds.H + 1)[:, None, None]
    return at_harmonic(ds.K, ds.M, ds.C, h, Om, _pairs(ds.extra, h, Om))


def dense_stack_derivative(ds: DynamicStiffness, Om: float, motion=None) -> np.ndarray:
    """(H+1, n, n) dS_h/dOmega of the dense strategies; with `motion` (H+1, n) complex
    its product with it, (H+1, n), from M and C applied to it (no dS formed)."""
    if motion is not None:
        blocks = (None, ds.M, ds.C) + tuple(t.matrix for t in ds.extra)
        return dynamic_derivative(blocks, ds.H, Om, motion[..., None], ds.extra)[..., 0]
    h = np.arange(ds.H + 1)[:, None, None]
    return harmonic_rate(ds.M, ds.C, h, Om, _pairs(ds.extra, h, Om, True))


def dynamic(blocks: tuple, H: int, Om: float, extra=()):
    """S of one block (K, M, C, *A_t) at w = h Omega for h = 0..H, (H+1, r, q)."""
    K, M, C = blocks[:3]
    w = np.arange(H + 1)[:, None, None] * Om
    S = np.empty((H + 1,) + K.shape, complex)
    np.subtract(K, w * w * M, out=S.real)
    np.multiply(w, C, out=S.imag)
    for A, a in _pairs(extra, np.arange(H + 1)[:, None, None], Om, matrices=blocks[3:]):
        S += a * A
    return S


def dynamic_derivative(blocks: tuple, H: int, Om: float, V=None, extra=()):
    """dS/dOmega = h (-2 w M + i C + ...) of one block for h = 0..H, (H+1, r, q); with V
    (H+1, q, k) its product with V, from M V and C V (no dS matrix formed)."""
    M, C = blocks[1:3]
    h = np.arange(H + 1)[:, None, None]
    if V is None:
        out = h * (-2 * h * Om * M + 1j * C)
    else:
        out = h * (-2 * h * Om * (M @ V) + 1j * (C @ V))
    for A, a in _pairs(extra, h, Om, True, blocks[3:]):
        out = out + a * (A if V is None else A @ V)
    return out


def sparse_stiffness(ds: DynamicStiffness, h: int, Om: float):
    """S_h of the sparse strategies (CSC; dense if K_h is, with a K_next coupling)."""
    K = ds.K[h]
    if sp.issparse(K):
        return at_harmonic(K, ds.M, ds.C, h, Om, _pairs(ds.extra, h, Om)).tocsc()
    return at_harmonic(np.asarray(K), dense(ds.M), dense(ds.C), h, Om,
                       [(dense(A), a) for A, a in _pairs(ds.extra, h, Om)])


def sparse_derivative(ds: DynamicStiffness, h: int, Om: float):
    """dS_h/dOmega of the sparse strategies."""
    dS = harmonic_rate(ds.M, ds.C, h, Om, _pairs(ds.extra, h, Om, True))
    return dS.tocsc() if sp.issparse(dS) else dS


def term_stiffness(terms, H: int, Om: float, derivative: bool = False) -> np.ndarray:
    """(H+1, n, n) sum_t a_t(h Omega) A_t (or its d/dOmega) of dense terms: with the
    terms (dA_t/dp, p_t, imag_t, q_t), dS_h/dp for a parameter p of the added terms."""
    h = np.arange(H + 1)[:, None, None]
    return sum(a * dense(A) for A, a in _pairs(terms, h, Om, derivative))


# ---- condensation onto the contact DOFs

def condense(ds: DynamicStiffness, Om: float, derivatives: bool = True, motion=None,
             pattern=None):
    """(St, dSt, Pt, dPt): condensed S_h, dS_h/dOmega (H+1 complex (nc, nc)), load and
    its derivative (H+1, nc).  With `motion` (H+1, nc) complex (the contact DOFs'
    harmonics), dSt is returned applied to it, dSt[h] @ motion[h] (H+1, nc).  With
    `pattern` (`parts.JacobianPattern`, strategy "parts", with `motion`), St is
    returned as its values on the pattern (H+1, p)."""
    if ds.strategy == "blocks":   # the algebra in `interior`, S formed here
        H, xt = ds.H, ds.extra
        return condense_blocks(ds.blocks, ds.loads, ds.c, ds.o, derivatives, motion,
                               lambda b: dynamic(b, H, Om, xt),
                               lambda b, V=None: dynamic_derivative(b, H, Om, V, xt))
    if ds.strategy == "dense":
        if ds.o.size == 0 and derivatives and motion is not None:   # nothing to condense
            return (dense_stack(ds, Om), dense_stack_derivative(ds, Om, motion), ds.loads,
                    np.zeros(motion.shape, complex))
        out = _condense_dense(ds, Om, derivatives)
    elif ds.strategy == "parts":
        if pattern is not None:
            if derivatives and motion is None:
                raise ValueError("condense: on a pattern, dS~ is applied to a motion: give it")
            return condense_parts(ds, Om, derivatives, pattern, motion)
        St, dSt, Pt, dPt = condense_parts(ds, Om, derivatives)
        out = (list(St), list(dSt) if derivatives else [], Pt, dPt)
    else:
        out = _condense_sparse(ds, Om, derivatives)
    if not (derivatives and motion is not None):
        return out
    St, dSt, Pt, dPt = out
    return St, np.einsum("hij,hj->hi", np.asarray(dSt), motion), Pt, dPt


def _condense_dense(ds: DynamicStiffness, Om: float, derivatives: bool):
    """All harmonics in batched numpy calls."""
    c, o, H = ds.c, ds.o, ds.H
    S = dense_stack(ds, Om)   # (H+1, n, n)
    P = ds.loads
    dS = dense_stack_derivative(ds, Om) if derivatives else None
    if o.size == 0:   # every DOF is a contact DOF: c = 0..n-1
        return S, dS, P, np.zeros((H + 1, c.size), complex) if derivatives else None
    Scc, Sco, Soc, Soo = S[:, c][:, :, c], S[:, c][:, :, o], S[:, o][:, :, c], S[:, o][:, :, o]
    sol = np.linalg.solve(Soo, np.concatenate([Soc, P[:, o, None]], axis=2))
    # contiguous copies: batched matmul on strided complex views falls back to a slow
    # loop in numpy (15-40x slower on a 136-DOF blade)
    X, z = np.ascontiguousarray(sol[..., :-1]), sol[..., -1]   # Soo^-1 Soc, Soo^-1 P_o
    St = Scc - Sco @ X
    Pt = P[:, c] - (Sco @ z[..., None])[..., 0]
    if not derivatives:
        return St, None, Pt, None
    dScc, dSco, dSoc, dSoo = (dS[:, c][:, :, c], dS[:, c][:, :, o], dS[:, o][:, :, c],
                              dS[:, o][:, :, o])
    Y = np.ascontiguousarray(
        np.linalg.solve(Soo.transpose(0, 2, 1), Sco.transpose(0, 2, 1)).transpose(0, 2, 1))
    dSt = dScc - dSco @ X - Y @ dSoc + Y @ dSoo @ X
    dPt = (-(dSco @ z[..., None]) + Y @ (dSoo @ z[..., None]))[..., 0]
    return St, dSt, Pt, dPt


def _block(ds, h, Om, rate=False):
    """(S_cc, S_co, S_oc, S_oo) of harmonic h (rate: of dS_h/dOmega) of the sparse
    strategy: from the blocks cut once, else (a dense K_h; "parts") sliced from S_h."""
    b, c, o = ds.blocks, ds.c, ds.o
    if not isinstance(b, SparseBlocks):
        S = sparse_derivative(ds, h, Om) if rate else sparse_stiffness(ds, h, Om)
        if sp.issparse(S):
            S = S.tocsr()
            return (S[c][:, c].toarray(), S[c][:, o], S[o][:, c], S[o][:, o].tocsc())
        return S[np.ix_(c, c)], S[np.ix_(c, o)], S[np.ix_(o, c)], S[np.ix_(o, o)]
    coeff = [a for _, a in _pairs(ds.extra, h, Om, rate)]
    pairs = [[(A[k], a) for A, a in zip(b.extra, coeff)] for k in range(4)]
    if rate:
        return tuple(harmonic_rate(b.M[k], b.C[k], h, Om, pairs[k]) for k in range(4))
    return tuple(at_harmonic(b.K[h][k], b.M[k], b.C[k], h, Om, pairs[k]) for k in range(4))


def _dense_c(A):
    return A.toarray() if sp.issparse(A) else A


class _Solver:
    """Factorisation of S_oo (dense LU or sparse LU), reused for several solves."""

    def __init__(self, A):
        if sp.issparse(A):
            self.lu = spla.splu(A.tocsc())
            self.solve = self.lu.solve
            self.solve_T = lambda b: self.lu.solve(b, trans="T")
        else:
            self.lu = sla.lu_factor(A, check_finite=False)
            self.solve = lambda b: sla.lu_solve(self.lu, b, check_finite=False)
            self.solve_T = lambda b: sla.lu_solve(self.lu, b, trans=1, check_finite=False)


def _condense_sparse(ds: DynamicStiffness, Om: float, derivatives: bool):
    """One sparse LU of S_oo per harmonic."""
    c, o = ds.c, ds.o
    St, dSt, Pt, dPt = [], [], [], []
    for h in range(ds.H + 1):
        Ph = ds.loads[h]
        if o.size == 0:
            St.append(np.asarray(_dense_c(sparse_stiffness(ds, h, Om)))[np.ix_(c, c)])
            Pt.append(Ph[c])
            if derivatives:
                dSt.append(np.asarray(_dense_c(sparse_derivative(ds, h, Om)))[np.ix_(c, c)])
                dPt.append(np.zeros(c.size, complex))
            continue
        Scc, Sco, Soc, Soo = _block(ds, h, Om)
        lu = _Solver(Soo)
        sol = lu.solve(np.column_stack([_dense_c(Soc), Ph[o][:, None]]))
        X, z = sol[:, :-1], sol[:, -1]           # X = Soo^-1 Soc, z = Soo^-1 P_o
        St.append(Scc - Sco @ X)
        Pt.append(Ph[c] - Sco @ z)
        if derivatives:
            dScc, dSco, dSoc, dSoo = _block(ds, h, Om, rate=True)
            # Y = Sco Soo^-1 via the transposed solve: Y^T = Soo^-T Sco^T
            Y = lu.solve_T(_dense_c(Sco).T).T
            dSt.append(dScc - dSco @ X - Y @ _dense_c(dSoc) + Y @ (dSoo @ X))
            dPt.append(-(dSco @ z) + Y @ (dSoo @ z))
    return St, dSt, np.array(Pt), np.array(dPt) if derivatives else None


def condense_parts(ds: DynamicStiffness, Om: float, derivatives: bool, pattern=None,
                   motion=None):
    """(S~, dS~, P~, dP~) of every harmonic, (H+1, nc, nc) and (H+1, nc), part by part
    (`parts.PartBlocks`), all harmonics and parts in batched dense solves:
    S~_h = S_cc - sum_k S_{c,o_k} S_{o_k o_k}^-1 S_{o_k,c}.  With `pattern` and
    `motion`: S~ on the pattern (H+1, p) and dS~ applied to the motion (H+1, nc)
    (`parts.on_pattern`, `parts.applied`), without the dense (nc, nc) matrices."""
    pb, c, xt = ds.blocks, ds.c, ds.extra
    h = np.arange(ds.H + 1)[:, None, None, None]              # harmonic, part, rows, cols
    hc = h[:, 0]

    def blocks(rate):   # S_oo, S_co, S_oc (or their rates); S_oc = S_co^T if symmetric
        S = [harmonic_rate(b[1], b[2], h, Om, _pairs(xt, h, Om, True, b[3:])) if rate
             else at_harmonic(*b[:3], h, Om, _pairs(xt, h, Om, matrices=b[3:]))
             for b in ((pb.oo, pb.co) if pb.symmetric else (pb.oo, pb.co, pb.oc))]
        return S if len(S) == 3 else S + [np.swapaxes(S[1], -1, -2)]

    Soo, Sco, Soc = blocks(False)
    P = ds.loads
    sol = np.linalg.solve(Soo, np.concatenate([Soc, P[:, pb.o][..., None]], axis=-1))
    X, z = sol[..., :-1], sol[..., -1:]
    cc = at_harmonic(*pb.ccv[:3], hc[:, 0], Om, _pairs(xt, hc[:, 0], Om, matrices=pb.ccv[3:]))
    St = (on_contact_dofs(pb, cc, -(Sco @ X)) if pattern is None
          else on_pattern(pb, pattern, cc, -(Sco @ X)))
    Pt = on_parts(pb, P[:, c].astype(complex), -(Sco @ z)[..., 0])
    if not derivatives:
        return St, None, Pt, None
    dSoo, dSco, dSoc = blocks(True)
    Y = (np.swapaxes(X, -1, -2) if pb.symmetric else   # Y = S_co S_oo^-1
         np.linalg.solve(np.swapaxes(Soo, -1, -2), np.swapaxes(Sco, -1, -2)).swapaxes(-1, -2))
    dcc = harmonic_rate(pb.ccv[1], pb.ccv[2], hc[:, 0], Om,
                        _pairs(xt, hc[:, 0], Om, True, pb.ccv[3:]))
    dparts = -(dSco @ X + Y @ dSoc - Y @ (dSoo @ X))
    dSt = (on_contact_dofs(pb, dcc, dparts) if pattern is None
           else applied(pb, dcc, dparts, motion))
    dPt = on_parts(pb, np.zeros(Pt.shape, complex), (-(dSco @ z) + Y @ (dSoo @ z))[..., 0])
    return St, dSt, Pt, dPt


# ---- recovery of the eliminated DOFs

def recover(ds: DynamicStiffness, Qc, Om: float) -> np.ndarray:
    """All DOFs' real coefficients Q (n, 2H+1) from the contact DOFs' Qc (nc, 2H+1):
    S_oo Q_o = P_o - S_oc Q_c per harmonic."""
    c, o, H = ds.c, ds.o, ds.H
    Q = np.zeros((ds.loads.shape[1], 2 * H + 1))
    Q[c] = Qc
    if o.size == 0:
        return Q
    if ds.strategy in ("blocks", "dense"):
        Qh = complex_harmonics(Qc)
        if ds.strategy == "blocks":
            ib = ds.blocks
            Soo, Soc = dynamic(ib.oo, H, Om, ds.extra), dynamic(ib.oc, H, Om, ds.extra)
            rhs = ds.loads[:, o] - (Soc @ Qh[..., None])[..., 0]
            Qo = np.linalg.solve(Soo, rhs[..., None])[..., 0]
        else:
            S = dense_stack(ds, Om)[:, o]
            rhs = ds.loads[:, o] - (S[:, :, c] @ Qh[..., None])[..., 0]
            Qo = np.linalg.solve(S[:, :, o], rhs[..., None])[..., 0]     # (H+1, no)
        Q[o, 0] = Qo[0].real
        Q[o, 1::2], Q[o, 2::2] = Qo[1:].real.T, -Qo[1:].imag.T
        return Q
    pb = ds.parts
    for h in range(H + 1):
        Qh = Qc[:, 0].astype(complex) if h == 0 else Qc[:, 2 * h - 1] - 1j * Qc[:, 2 * h]
        if pb is not None:       # part by part, batched dense solves (as `condense_parts`)
            Soo, Soc = (at_frequency(*b[:3], h * Om, _pairs(ds.extra, h, Om, matrices=b[3:]))
                        for b in (pb.oo, pb.oc))
            rhs = ds.loads[h][pb.o] - (Soc @ Qh[pb.ck][..., None])[..., 0]
            Qo = np.empty(o.size, complex)
            Qo[np.searchsorted(o, pb.o.ravel())] = np.linalg.solve(Soo, rhs[..., None]).ravel()
        else:
            _, _, Soc, Soo = _block(ds, h, Om)
            Qo = _Solver(Soo).solve(ds.loads[h][o] - Soc @ Qh)
        if h == 0:
            Q[o, 0] = Qo.real
        else:
            Q[o, 2 * h - 1], Q[o, 2 * h] = Qo.real, -Qo.imag
    return Q


# ---- operators of all DOFs in the real layout (no condensation)

def term_layout(t: Term, H: int, Om: float) -> np.ndarray:
    """(2H+1, 2H+1) real-layout factor F of a term: a A Q_h <-> (A Q) F^T; i w is Om D
    (`derivative_matrix`), w^p Omega^q the scale (h Om)^p Om^q of harmonic h."""
    hh = np.concatenate([[0.0], np.repeat(np.arange(1.0, H + 1), 2)])
    scale = Om ** t.omega_power
    if t.imag:
        return scale * (hh * Om)[:, None] ** (t.power - 1) * (Om * derivative_matrix(H))
    return scale * np.diag((hh * Om) ** t.power)


def apply_full(K, C, M, Q, Om: float, D, extra=(), rate: bool = False):
    """K Q + Om C Q D^T + Om^2 M Q (D D)^T (+ the terms' A Q F^T) of Q (n, 2H+1): the
    full residual's linear part (|K|, |C|, |M|, |D|: its round-off); rate=True: d/dOmega,
    C Q D^T + 2 Om M Q (D D)^T + (p + q)/Om A Q F^T (F_t is Om^(p+q) times a constant)."""
    if rate:
        out = (C @ Q) @ D.T + 2.0 * Om * (M @ Q) @ (D @ D).T
    else:
        out = K @ Q + Om * (C @ Q) @ D.T + Om**2 * (M @ Q) @ (D @ D).T
    return apply_terms(Q, Om, extra, rate, out)


def apply_coupling(sys, Q, Om: float, D, absolute: bool = False):
    """The forces [N] (n, 2H+1) of a cyclic sector's linear coupling to its neighbours on
    the travelling wave Q (real layout): (K, C, M)_next acting on the next sector's
    motion shift(Q, phi) and their transposes on the previous one's, shift(Q, -phi)
    (`apply_full`); absolute=True: the same with |X_next|, |shift(Q)| and D as given
    (the round-off bound); 0 without a coupling."""
    cy = sys.cyclic
    parts = [coupling(sys, name) for name in ("K", "C", "M")]
    if cy is None or all(X is None for X in parts):
        return 0.0
    K, C, M = (np.zeros((sys.n_dof, sys.n_dof)) if X is None else (np.abs(X) if absolute else X)
               for X in parts)
    out = 0.0
    for sign, (Kx, Cx, Mx) in ((1.0, (K, C, M)), (-1.0, (K.T, C.T, M.T))):
        Qs = time_shift(Q, sign * cy.phase)
        out = out + apply_full(Kx, Cx, Mx, np.abs(Qs) if absolute else Qs, Om, D)
    return out


def apply_terms(Q, Om: float, terms, rate: bool = False, out=None):
    """out + sum_t A_t Q F_t^T (rate=True: d/dOmega of the sum) of Q (n, 2H+1); out None:
    the terms alone (an EPMC term's derivative in zeta: A_t = dA/dzeta)."""
    H = (Q.shape[1] - 1) // 2
    for t in terms:
        f = (t.power + t.omega_power) / Om if rate else 1.0
        add = f * (t.matrix @ Q) @ term_layout(t, H, Om).T
        out = add if out is None else out + add
    return np.zeros(Q.shape) if out is None else out


def full_operator(sys, Om: float, H: int, extra=()) -> np.ndarray:
    """K (x) I + Om C (x) D + Om^2 M (x) D^2 (+ A_t (x) F_t) acting on Q (n, 2H+1)
    row-major, dense (n nh, n nh); K the system's own (no inter-sector coupling)."""
    if sp.issparse(sys.K):  # only the (n nh)^2 result is dense, no (n, n) copies
        D, I = derivative_matrix(H), np.eye(2 * H + 1)
        L = (sp.kron(sys.K, I) + Om * sp.kron(sys.C, D) + Om**2 * sp.kron(sys.M, D @ D)
             ).toarray()
    else:   # filled per harmonic (D^2 = diag(-h^2)); the same as the Kronecker sum
        K, C, M = dense(sys.K), dense(sys.C), dense(sys.M)
        n, nh = K.shape[0], 2 * H + 1
        L4 = np.zeros((n, nh, n, nh))
        h2 = np.concatenate([[0.0], np.repeat(np.arange(1.0, H + 1) ** 2, 2)])
        k = np.arange(nh)
        L4[:, k, :, k] = K - (Om**2 * h2)[:, None, None] * M
        ci, si = np.arange(1, nh, 2), np.arange(2, nh, 2)
        hD = Om * np.arange(1.0, H + 1)[:, None, None] * C     # Om C (x) D, D[c, s] = h
        L4[:, ci, :, si] = hD
        L4[:, si, :, ci] = -hD
        L = L4.reshape(n * nh, n * nh)
    for t in extra:
        L = L + np.kron(dense(t.matrix), term_layout(t, H, Om))
    return L


def motion_matrices(M, C, Om: float, extra=()):
    """Mass and damping (M, C) at Omega of M q'' + C q' + K q with the added terms that
    have that form (for Hill's method): i w Omega^q A is Omega^q A q' (added to C),
    w^2 Omega^q A is -Omega^q A q'' (taken from M); a term of another power of w has
    no place there (ValueError)."""
    for t in extra:
        A = Om ** t.omega_power * dense(t.matrix)
        if (t.power, t.imag) == (1, True):
            C = C + A
        elif (t.power, t.imag) == (2, False):
            M = M - A
        else:
            raise ValueError(f"an added term w^{t.power}{' i' if t.imag else ''} A has no "
                             "place in M q'' + C q' + K q")
    return M, C
