"""The static normal load of the contacts: what the preload n0 becomes once the
structure deflects under it (paper Eq. 1, 4).

The element's normal load is n = n0 + kv v (Eq. 1).  At zero excitation with every
contact closed and stuck, the harmonic-0 balance is linear: a fully stuck slider
sits in the middle of its band (`contact.element`), i.e. at the static tangential
displacement, so f_u = 0 and only the normal springs act,

    (K0 + Bn0^T diag(kv) Bn0) q0 = F0 - Bn0^T n0,     v0 = Bn0 q0,
    s = n0 + kv v0                                   (static normal load [N]),

with F0 the static part of the load, K0 the stiffness a static (h = 0) state sees
(`system.coupled_stiffness` at angle 0) and, for a cyclic sector, Bn0 = Bn + Bn_next
(the next sector's static displacement equals this one's).  The structure gives way
under the preload (v0 < 0), so s < n0 per element when F0 = 0.

s is affine in n0, so a requested static load per contact (face total) fixes n0:
with n0 = D p (D (E, C): each contact's distribution of a unit face total over its
elements, `contacts.contact_elements` with preload 1) and the face sums
S = owner-sum (E -> C),

    S s = S D p + S kv Bn0 A^-1 (F0 - Bn0^T D p) = target   (C x C linear in p),

one solve of A = K0 + Bn0^T kv Bn0 with C + 1 right-hand sides.

The contact is unilateral: an element whose s would be a tension is open (a gap,
its springs carry nothing), found by active sets (`static_state`).  That state is
what the pipeline calls the static contact state everywhere: the datasets' static
normal loads (compressive only, 0 where open), the stuck linear limit (the closed
elements stuck, the open ones open: `stuck_limit_system`), a requested static load
(the active set iterated with n0: `preload_for_unilateral_load`) and the state a
nonlinear mode starts from.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .contacts import FaceContact, ShroudPair
from .scene import Scene
from .build import blade_contact_maps, build_system
from .system import System, contact_set, coupled_stiffness, with_preload

NORMAL_LOAD = "normal_load"   # the case key of a requested static normal load [N]


def contact_owner(scene: Scene) -> np.ndarray:
    """The index in `scene.contacts` of each element of a case's `System` (one
    sector): every node (pair) of a face contact belongs to its face; a contact over
    named DOFs is one element."""
    if any(isinstance(c, (FaceContact, ShroudPair)) for c in scene.contacts):
        return np.asarray(blade_contact_maps(scene, full=True)[4], dtype=int)
    return np.arange(len(scene.contacts))


def _static_operators(system: System, closed=None):
    """(A = K0 + Bn0^T kv Bn0, Bn0, F0) of the static problem (module doc) with the
    springs of the `closed` elements (default: all)."""
    cs = contact_set(system)
    K0 = coupled_stiffness(system, 0.0)
    Bn = cs.maps[-1]
    if cs.maps_next:
        Bx = cs.maps_next[-1]
        Bn = (sp.csr_matrix(Bn, dtype=float) + sp.csr_matrix(Bx, dtype=float)
              if sp.issparse(Bn) or sp.issparse(Bx)
              else np.asarray(Bn, float) + np.asarray(Bx, float))
    kv = cs.elements.kv if closed is None else np.where(closed, cs.elements.kv, 0.0)
    F0 = np.asarray(system.forcing)[:, 0].real.astype(float)
    if sp.issparse(K0) or sp.issparse(Bn):
        Bs = sp.csr_matrix(Bn, dtype=float)
        A = (sp.csr_matrix(K0, dtype=float) + Bs.T @ sp.diags(kv) @ Bs).tocsc()
        return A, Bs, F0
    Bn = np.asarray(Bn, float)
    return np.asarray(K0, float) + Bn.T @ (kv[:, None] * Bn), Bn, F0


def _solve(A, rhs):
    """A^-1 rhs (n, k): sparse LU or a dense symmetric solve; ValueError if singular."""
    if sp.issparse(A):
        X = spla.splu(A).solve(np.asarray(rhs, float))
    else:
        try:
            X = sla.solve(A, rhs, assume_a="sym")
        except (sla.LinAlgError, ValueError) as exc:
            raise ValueError(f"the static problem with the contacts closed is singular: {exc}") \
                from None
    if not np.all(np.isfinite(X)):
        raise ValueError("the static problem with the contacts closed is singular")
    return X


def static_normal_load(system: System) -> np.ndarray:
    """s = n0 + kv v0 [N] per element (E,): the normal load of each element in the
    static state with every contact closed and stuck at zero excitation (module doc)."""
    el = contact_set(system).elements
    if el.size == 0:
        return np.zeros(0)
    A, Bn, F0 = _static_operators(system)
    q0 = _solve(A, (F0 - Bn.T @ el.n0)[:, None])[:, 0]
    return el.n0 + el.kv * (Bn @ q0)


@dataclass(frozen=True)
class StaticState:
    """The unilateral static contact state at zero excitation (`static_state`): per
    element the normal load `load` [N] (> 0 where closed, 0 where open), `closed`, and
    `trial` = n0 + kv v0 [N] with the state's displacement (the load where closed,
    <= 0 where open: minus kv times the gap); `q0` (n,) [m] the static displacement."""

    load: np.ndarray
    closed: np.ndarray
    trial: np.ndarray
    q0: np.ndarray

    @property
    def tensile(self) -> np.ndarray:
        """The elements that would pull (trial < 0): open.  An element at exactly zero
        load (n0 = 0 and nothing pressing) touches without force: not tensile."""
        return self.trial < 0.0


def static_state(system: System, max_sweeps: int | None = None) -> StaticState:
    """The static contact solution at zero excitation with unilateral normal contact
    -- an element is closed with s = n0 + kv v0 > 0 or open with s = 0 and
    n0 + kv v0 <= 0 (a gap; its spring carries nothing) -- found by active sets: solve
    with the closed elements' springs, open those pulling (s <= 0), close the open ones
    that penetrate, until nothing changes (ValueError if it does not settle).
    Tangentially as `static_normal_load` (a stuck slider at the middle of its band
    carries no force).  With every element closed it is `static_normal_load`."""
    el = contact_set(system).elements
    E = el.size
    if E == 0:
        e = np.zeros(0)
        return StaticState(e, np.zeros(0, bool), e, np.zeros(system.n_dof))
    kv = np.asarray(el.kv, float)
    closed = np.ones(E, bool)
    for _ in range(max_sweeps or 2 * E + 2):
        Ac, Bn, F0 = _static_operators(system, closed)
        q0 = _solve(Ac, (F0 - Bn.T @ np.where(closed, el.n0, 0.0))[:, None])[:, 0]
        trial = el.n0 + kv * (Bn @ q0)
        now = trial > 0.0
        if np.array_equal(now, closed):
            return StaticState(np.where(closed, trial, 0.0), closed, trial, q0)
        closed = now
    raise ValueError(f"the static contact solution did not settle in {max_sweeps or 2 * E + 2} "
                     "active-set sweeps")


def static_contact(system: System, max_sweeps: int | None = None) -> tuple:
    """(s (E,) [N], closed (E,) bool) of `static_state`."""
    st = static_state(system, max_sweeps)
    return st.load, st.closed


def stuck_limit_system(system: System, state: StaticState | None = None) -> System:
    """The system whose "small" linear limit (`system.linear_stiffness`) is the stuck
    limit about the unilateral static state: every element that is not tensile
    (`StaticState.tensile`) stuck (ku, kv), the tensile ones open.  Only the sign of n0
    is read there, so n0 becomes +1 or -1 N; use it for linear limits only."""
    st = static_state(system) if state is None else state
    if st.closed.size == 0:
        return system
    return with_preload(system, np.where(st.tensile, -1.0, 1.0))


def face_totals(values, owner, n_contacts: int) -> np.ndarray:
    """Sum of per-element `values` (..., E) over each contact's elements -> (..., C)."""
    values = np.asarray(values, float)
    S = np.zeros((values.shape[-1], n_contacts))
    S[np.arange(owner.size), owner] = 1.0
    return values @ S


def preload_for_static_load(system: System, owner, distribution, target,
                            closed=None) -> np.ndarray:
    """n0 (E,) [N] whose static normal loads sum to `target` (C,) [N] over each
    contact's elements, n0 = distribution * p[owner] (`distribution` (E,): each
    element's share of a unit face total), with the `closed` elements (default: all)
    carrying load and the others open.  Linear: one solve (module doc)."""
    el = contact_set(system).elements
    owner = np.asarray(owner, int)
    target = np.asarray(target, float)
    C = target.size
    on = np.ones(el.size, bool) if closed is None else np.asarray(closed, bool)
    D = np.zeros((el.size, C))
    D[np.arange(el.size), owner] = np.asarray(distribution, float)
    A, Bn, F0 = _static_operators(system, on)
    X = _solve(A, np.column_stack([Bn.T @ (D * on[:, None]), F0]))
    V = Bn @ X                                    # v0 of each unit face load, of F0
    G = face_totals(((D - el.kv[:, None] * V[:, :C]) * on[:, None]).T, owner, C).T   # (C, C)
    c = face_totals(np.where(on, el.kv * V[:, C], 0.0), owner, C)
    try:
        p = np.linalg.solve(G, target - c)
    except np.linalg.LinAlgError:
        raise ValueError("no static preload gives the requested normal load: a contact has "
                         "no element in contact") from None
    return D @ p


def preload_for_unilateral_load(system: System, owner, distribution, target,
                                max_sweeps: int | None = None) -> np.ndarray:
    """`preload_for_static_load` with unilateral contact: the elements in tension at
    the n0 found do not count towards the target.  The active set depends on n0, so
    solve n0 with the current set (first: every element closed), recompute the set
    (`static_state`), until it settles; ValueError naming the sweeps if it does not."""
    E = contact_set(system).elements.size
    sweeps = max_sweeps or 2 * E + 2
    closed = np.ones(E, bool)
    for _ in range(sweeps):
        n0 = preload_for_static_load(system, owner, distribution, target, closed)
        now = static_state(with_preload(system, n0)).closed
        if np.array_equal(now, closed):
            return n0
        closed = now
    raise ValueError(f"the preload for the requested static normal load of "
                     f"{', '.join(f'{x:g}' for x in np.atleast_1d(target))} N per contact "
                     f"did not settle: the elements in contact still change after {sweeps} "
                     "sweeps")


def case_system(scene: Scene, case: dict | None = None) -> System:
    """`build_system` of a case; a case with `normal_load` (the static normal load of
    every contact, face total [N], compressive elements only) gets the preload n0 that
    produces it (`preload_for_unilateral_load`)."""
    case = dict(case or {})
    if NORMAL_LOAD not in case:
        return build_system(scene, case)
    target = float(case.pop(NORMAL_LOAD))
    unit = build_system(scene, {**case, "preload": 1.0})
    owner = contact_owner(scene)
    n0 = preload_for_unilateral_load(unit, owner, contact_set(unit).elements.n0,
                                     np.full(len(scene.contacts), target))
    return with_preload(unit, n0)
