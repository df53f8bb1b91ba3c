"""Contacts of a scene: Yang-Menq elements (paper Eq. 1, 9, 10) given as rows over
named DOFs (`DofContact`; in a cyclic assembly also over the next sector's) or on
every node of an FE contact face against a rigid wall (`FaceContact`), and their
parameters with a case applied (`contact_elements`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..contact import YangMenq


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


def contact_elements(contacts, case: dict, owner=None, weights=None) -> YangMenq:
    """Yang-Menq parameters of `contacts` with a case applied, one element per row of
    `owner` (the contact of each element; default one per contact).  A `FaceContact`'s
    preload is the total of its face: shared equally ("per_node") or, with ku and kv,
    by node area ("per_face"; `weights[i]` the areas of contact i's nodes)."""
    case = dict(case or {})
    owner = np.arange(len(contacts)) if owner is None else np.asarray(owner)
    ku, kv, mu, n0 = (case_parameter(contacts, owner, case, *p) for p in
                      (("ku", "ku"), ("kv", "kv"), ("mu", "mu"), ("preload", "n0")))
    for i, c in enumerate(contacts):
        if not isinstance(c, FaceContact):
            continue
        on = owner == i
        if c.stiffness == "per_face":
            a = weights[i]
            if a is None or not np.all(a > 0):
                raise ValueError(f"contact {c.name!r}: stiffness = 'per_face' needs a positive "
                                 "area per face node")
            share = a / a.sum()
            ku[on], kv[on], n0[on] = ku[on] * share, kv[on] * share, n0[on] * share
        else:
            n0[on] = n0[on] / max(int(on.sum()), 1)
    return YangMenq(ku=ku, kv=kv, mu=mu, n0=n0)
