"""Contacts of a scene: Yang-Menq elements (paper Eq. 1, 9, 10) given as rows over
named DOFs (`DofContact`; in a cyclic assembly also over the next sector's), on
every node of an FE contact face against a rigid wall (`FaceContact`), or on every
node pair of the right shroud face of a blade in a disk and the left face of the
next blade (`ShroudPair`), and their parameters with a case applied
(`contact_elements`).

Shroud pairs (`shroud_pair_maps`): the neighbour's displacement is a vector of ITS
frame, turned by the pitch alpha = 2 pi / N into this sector's, so the relative
displacement of the pair (x_R of blade j, x_L of blade j+1) is

    d = R(alpha) q^L_{j+1} - q^R_j,   u = t . d,   v = -n . d,

n the outward normal of the right face (v > 0 closes the gap), t a tangent in the
face: Bt = -t^T S_R, Bt_next = t^T R(alpha) S_L, Bn = n^T S_R,
Bn_next = -n^T R(alpha) S_L (S: the selection of a node's 3 DOFs, or the point
motion P of a face whose points move with several DOFs).

A contact with friction = "2d" slides in its whole plane (`contact.friction2d`): its
elements have two tangents, t1 = t (above) and t2 = n x t1, and the normal, mapped
alike (`fe_plane_maps`); they are a law's elements (`contact.laws.LawElements`),
not the Yang-Menq set of the system."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ..contact.laws import ContactElements, LawElements
from ..contact.registry import friction_elements
from ..structure.disk import pairing
from ..structure.fe_model import project_rows


@dataclass(frozen=True, eq=False)
class DofContact:
    """One Yang-Menq element (paper Eq. 1, 9, 10): u = bt . q, v = bn . q over the
    scene's contact DOFs (the system's DOFs; in a cyclic assembly followed by the
    next sector's)."""

    name: str
    bt: np.ndarray          # [-]
    bn: np.ndarray          # [-], zeros when the normal load is constant
    ku: float               # [N/m]
    kv: float               # [N/m]
    mu: float               # [-]
    n0: float | None        # [N]; None when the case's `preload` sets it


@dataclass(frozen=True)
class FaceContact:
    """Yang-Menq elements on every node of one FE contact face, against a rigid wall."""

    name: str
    face: str               # node set of the blade (shroud_left / shroud_right)
    ku: float               # [N/m] per node (face total when stiffness = "per_face")
    kv: float               # [N/m] per node (face total when stiffness = "per_face")
    mu: float               # [-]
    n0: float | None        # [N] total over the face; None: the case's preload
    stiffness: str = "per_node"  # "per_face": ku, kv are face totals shared by area
    friction: str = "1d"    # "2d": slip in the face plane (tangents t, t2 of the face)
    ku2: float | None = None     # [N/m] along t2 (friction = "2d"); None: ku


FRICTION = ("1d", "2d")     # along one tangent (Yang-Menq) or in the contact plane


@dataclass(frozen=True)
class ShroudPair:
    """Yang-Menq elements on every node pair of the right shroud face of this sector
    and the left face of the next one (a blade in a disk, paired by the pitch
    rotation).  tangent: the slip direction (3-vector, global axes of this blade,
    projected into the face); None: the disk's circumferential direction at the face
    centre projected into the face (the axial direction X if that is degenerate).
    interference: the overlap [m] of the faces in the assembled position (> 0: they
    press, < 0: a gap); it replaces n0: each element's preload is
    n0_k = kv_k (interference + v_c,k), v_c the relative normal displacement of the
    pair under the centrifugal load of the blades alone (`structure.rotation`, zero at
    rest) -- the harmonic balance then deflects the structure under it, as under any
    preload (`static_load`)."""

    name: str
    ku: float               # [N/m] per node pair (face total when stiffness = "per_face")
    kv: float               # [N/m] per node pair (face total when stiffness = "per_face")
    mu: float               # [-]
    n0: float | None        # [N] total over the face; None: the case's preload
    tangent: tuple | None = None   # [-] direction, global axes
    stiffness: str = "per_node"    # "per_face": ku, kv are face totals shared by area
    interference: float | None = None   # [m] overlap (> 0) or gap (< 0); sets n0
    friction: str = "1d"           # "2d": slip in the face plane (t1 = tangent, t2 = n x t1)
    ku2: float | None = None       # [N/m] along t2 (friction = "2d"); None: ku


def in_face(e, n) -> np.ndarray | None:
    """The unit projection of e into the plane of unit normal n (None if degenerate)."""
    e = np.asarray(e, float)
    t = e - (e @ n) * n
    norm = np.linalg.norm(t)
    return t / norm if norm > 1e-6 * np.linalg.norm(e) else None


def pair_frame(blade, pair: ShroudPair, disk) -> tuple:
    """(t, n) of a shroud pair: n the outward unit normal of the right face, t the
    pair's tangent (module doc) projected into the face."""
    fr = blade.frames["shroud_right"]
    n = np.asarray(fr.normal, float)
    if pair.tangent is not None:
        t = in_face(pair.tangent, n)
        if t is None:
            raise ValueError(f"contact {pair.name!r}: tangent {pair.tangent!r} is normal to "
                             "the shroud face (no slip direction in the face)")
        return t, n
    t = in_face(disk.circumferential(np.mean(fr.points, axis=0)), n)
    return (t if t is not None else in_face([1.0, 0.0, 0.0], n)), n


def shroud_pair_maps(blade, pair: ShroudPair, disk, plane: bool = False) -> tuple:
    """(Bt, Bn, Bt_next, Bn_next) sparse (k, n_full) of one `ShroudPair` on the
    unreduced blade: one row per right-face point and the left face under it (its
    partner node, or interpolated on the left facet it falls on: `structure.disk.pairing`),
    the maps of the module doc with the selection S of a node's 3 DOFs generalised to the faces' point motion P (d_k = P_k q,
    `fe_model.ContactFrame.point_motion`; a rigid shroud's points move with its body).
    plane=True: ((B1, B2, Bn), (B1_next, B2_next, Bn_next)) along t1, t2 = n x t1 and n."""
    for face in ("shroud_right", "shroud_left"):
        if face not in blade.frames:
            raise ValueError(f"contact {pair.name!r}: the blade has no face {face!r}")
    t, n = pair_frame(blade, pair, disk)
    right, left_face = blade.frames["shroud_right"], blade.frames["shroud_left"]
    W = pairing(right.points, left_face.points, disk, left_face.facets,
                facets_right=right.facets)
    try:
        Pr = right.point_motion(blade.n_dof)
        Pl = left_face.point_motion(blade.n_dof)
    except ValueError as exc:
        raise ValueError(f"contact {pair.name!r}: {exc}") from None
    if W.nnz == W.shape[0] and np.all(W.data == 1.0):   # node to node: the rows themselves
        Pl = Pl[(3 * W.indices[:, None] + np.arange(3)).ravel()]
    else:                                               # interpolated on the left facets
        Pl = (sp.kron(W, sp.identity(3), format="csr") @ Pl).tocsr()
    Ra = disk.rotation(disk.pitch_angle)
    if plane:
        dirs = (t, np.cross(n, t), -n)     # u1, u2, and v = -n . d
        return (tuple(rows_of(Pr, -e) for e in dirs), tuple(rows_of(Pl, Ra.T @ e) for e in dirs))
    return (rows_of(Pr, -t), rows_of(Pr, n), rows_of(Pl, Ra.T @ t), rows_of(Pl, -(Ra.T @ n)))


def rows_of(P, vec) -> sp.csr_matrix:
    """`project_rows` without the round-off direction cosines of a face's SVD (a zero
    column keeps its DOF out of the condensed harmonic-balance unknowns)."""
    vec = np.where(np.abs(vec) < 1e-12, 0.0, vec)
    B = project_rows(P, vec)
    B.eliminate_zeros()
    return B


def fe_plane_maps(blade, contacts, disk=None) -> tuple:
    """(maps, maps_next, owner, weights) of the friction = "2d" `FaceContact`s and
    `ShroudPair`s of an FE blade, in the given order: maps and maps_next three sparse
    (E, n_full) each, along t1, t2 = n x t1 and the normal (zero next-sector maps for a
    face against a wall), the contact of each element and each contact's node areas."""
    own, nxt, owner, weights = [], [], [], []
    for i, c in enumerate(contacts):
        if isinstance(c, ShroudPair):
            if disk is None:
                raise ValueError(f"contact {c.name!r}: a shroud pair needs the blade's disk "
                                 "placement (Blade(..., disk=DiskPlacement(R, N)))")
            a, b = shroud_pair_maps(blade, c, disk, plane=True)
            weights.append(blade.frames["shroud_right"].weights)
        else:
            fr = blade.frames[c.face]
            P = fr.point_motion(blade.n_dof)
            t = np.asarray(fr.tangent, float)
            a = tuple(rows_of(P, e) for e in (t, np.cross(fr.normal, t), fr.normal))
            b = tuple(sp.csr_matrix(B.shape) for B in a)
            weights.append(fr.weights)
        own.append(a)
        nxt.append(b)
        owner += [i] * a[0].shape[0]
    if not own:
        z = sp.csr_matrix((0, blade.n_dof))
        return (z,) * 3, (z,) * 3, np.zeros(0, int), []
    stack = [tuple(sp.vstack([m[d] for m in maps]).tocsr() for d in range(3))
             for maps in (own, nxt)]
    return stack[0], stack[1], np.asarray(owner), weights


def fe_contact_maps(blade, contacts, disk=None) -> tuple:
    """(Bt, Bn, Bt_next, Bn_next, owner, weights) of the `FaceContact`s and
    `ShroudPair`s of an FE blade, in the given order: sparse (E, n_full) maps (zero
    `_next` rows for faces against a wall), the contact of each element and each
    contact's node areas [m^2] (for stiffness = "per_face")."""
    maps, owner, weights = [], [], []
    for i, c in enumerate(contacts):
        if isinstance(c, ShroudPair):
            if disk is None:
                raise ValueError(f"contact {c.name!r}: a shroud pair needs the blade's disk "
                                 "placement (Blade(..., disk=DiskPlacement(R, N)))")
            maps.append(shroud_pair_maps(blade, c, disk))
            weights.append(blade.frames["shroud_right"].weights)
        else:
            Bt, Bn, _ = face_maps(blade, (c,))
            z = sp.csr_matrix(Bt.shape)
            maps.append((Bt, Bn, z, z))
            weights.append(blade.frames[c.face].weights)
        owner += [i] * maps[-1][0].shape[0]
    if not maps:
        z = sp.csr_matrix((0, blade.n_dof))
        return z, z, z, z, np.zeros(0, int), []
    out = tuple(sp.vstack([m[j] for m in maps]).tocsr() for j in range(4))
    return out + (np.asarray(owner), weights)


def blade_contact_sets(blade, faces, disk, case: dict, shift=None) -> tuple:
    """((Bt, Bn, Bt_next, Bn_next), elements, plane) of an FE blade's face contacts and
    shroud pairs with a case applied, on the unreduced blade: the Yang-Menq maps and
    elements, and `plane`, the `LawElements` of the 2D friction law (or None) -- a
    scene's contacts slide one way (all friction = "1d" or all "2d"; with "2d" the
    Yang-Menq set is empty).  shift (n_full,) [m]: the blade's centrifugal
    displacement, for the pairs' closure under an `interference` (None: at rest)."""
    kinds = {getattr(c, "friction", "1d") for c in faces}
    if len(kinds) > 1:
        raise ValueError("the contacts of a scene slide along one tangent (friction = \"1d\") "
                         "or in the contact plane (\"2d\"), not some each way")
    if kinds != {"2d"}:
        Bt, Bn, Bt_next, Bn_next, owner, weights = fe_contact_maps(blade, faces, disk)
        closure = None if shift is None else (Bn + Bn_next) @ shift
        return ((Bt, Bn, Bt_next, Bn_next),
                contact_elements(faces, case, owner, weights, closure), None)
    maps, maps_next, owner, weights = fe_plane_maps(blade, faces, disk)
    closure = None if shift is None else (maps[2] + maps_next[2]) @ shift
    law = contact_elements(faces, case, owner, weights, closure, "friction_2d")
    z = sp.csr_matrix((0, blade.n_dof))
    empty = friction_elements(ku=np.zeros(0), kv=np.zeros(0), mu=np.zeros(0), n0=np.zeros(0))
    nxt = maps_next if any(isinstance(c, ShroudPair) for c in faces) else ()
    return (z, z, z, z), empty, LawElements(law, maps, nxt)


def face_maps(blade, contacts) -> tuple:
    """(Bt, Bn) sparse (E, n_full) over all nodes of the `FaceContact`s, and the
    contact of each element."""
    Bt, Bn, owner = [], [], []
    for i, c in enumerate(contacts):
        t, n, _ = blade.frames[c.face].maps(blade.n_dof)
        # drop round-off direction cosines (~1e-17 from the SVD of the face): a
        # zero column keeps its DOF out of the condensed HBM unknowns
        for B in (t, n):
            B.data[np.abs(B.data) < 1e-12] = 0.0
            B.eliminate_zeros()
        Bt.append(t)
        Bn.append(n)
        owner += [i] * t.shape[0]
    if not Bt:
        return sp.csr_matrix((0, blade.n_dof)), sp.csr_matrix((0, blade.n_dof)), np.zeros(0, int)
    return sp.vstack(Bt).tocsr(), sp.vstack(Bn).tocsr(), np.asarray(owner)


def case_parameter(contacts, owner, case, name, attr):
    """One Yang-Menq parameter per element: the case's value of `name`, else each
    contact's `attr` (ValueError when neither is set)."""
    if name in case:
        return np.full(owner.size, float(case[name]))
    vals = [getattr(c, attr) for c in contacts]
    if any(v is None for v in vals):
        raise ValueError(f"{attr} of a contact is unset and the case gives no {name!r}")
    return np.array(vals, dtype=float)[owner]


def contact_elements(contacts, case: dict, owner=None, weights=None,
                     closure=None, law: str = "yang_menq") -> ContactElements:
    """The elements (`registry.friction_elements` of the law named `law`: Yang-Menq,
    or "friction_2d" for friction = "2d") of `contacts` with a case applied, one
    element per row of
    `owner` (the contact of each element; default one per contact).  A `FaceContact`'s
    (or `ShroudPair`'s) preload is the total of its face: shared equally ("per_node")
    or, with ku and kv, by node area ("per_face"; `weights[i]` the areas of contact
    i's nodes).  A shroud pair with an `interference` takes n0_k = kv_k (interference
    + closure_k) instead, `closure` (E,) [m] the centrifugal v_c (default zero); a
    case's `interference` [m] is every shroud pair's.  The 2D law's ku2 (along the
    second tangent) is a contact's own, else its ku."""
    case = dict(case or {})
    owner = np.arange(len(contacts)) if owner is None else np.asarray(owner)
    if "interference" in case:
        if not any(isinstance(c, ShroudPair) for c in contacts):
            raise ValueError("a case's interference is of shroud pairs; no contact is one")
        contacts = [replace(c, interference=float(case["interference"]), n0=None)
                    if isinstance(c, ShroudPair) else c for c in contacts]
    pressed = [i for i, c in enumerate(contacts) if getattr(c, "interference", None) is not None]
    ku, kv, mu = (case_parameter(contacts, owner, case, *p) for p in
                  (("ku", "ku"), ("kv", "kv"), ("mu", "mu")))
    n0 = case_parameter([replace(c, n0=0.0) if i in pressed else c   # set below
                         for i, c in enumerate(contacts)], owner, case, "preload", "n0")
    ku2 = ku.copy()
    for i, c in enumerate(contacts):
        if getattr(c, "ku2", None) is not None:
            ku2[owner == i] = c.ku2
    for i, c in enumerate(contacts):
        if not isinstance(c, (FaceContact, ShroudPair)):
            continue
        on = owner == i
        if c.stiffness == "per_face":
            a = weights[i]
            if a is None or not np.all(a > 0):
                raise ValueError(f"contact {c.name!r}: stiffness = 'per_face' needs a positive "
                                 "area per face node")
            share = a / a.sum()
            ku[on], kv[on], n0[on] = ku[on] * share, kv[on] * share, n0[on] * share
            ku2[on] = ku2[on] * share
        else:
            n0[on] = n0[on] / max(int(on.sum()), 1)
        if i in pressed:
            gap = np.zeros(int(on.sum())) if closure is None else np.asarray(closure)[on]
            n0[on] = kv[on] * (c.interference + gap)
    extra = {"ku2": ku2} if law == "friction_2d" else {}
    return friction_elements(law, ku=ku, kv=kv, mu=mu, n0=n0, **extra)
