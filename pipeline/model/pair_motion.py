"""The in-plane relative motion of a 1D shroud pair's faces, along its slip direction
and along the direction it leaves free.

A `ShroudPair` with friction = "1d" carries a Yang-Menq element per node pair: a
tangential spring and Coulomb slider along t (`contacts.pair_frame`) and the normal
spring along n.  The relative displacement along the other in-plane direction
b = n x t meets no force at all.  `plane_rows` gives, for each such pair of a scene,
the rows mapping a case's system coordinates q (one sector's: the Craig-Bampton
coordinates of a reduced blade, whose boundary holds the face DOFs, so the rows are
exact; a disk sector's after its cut, `blade_cache.sector_map`) to the relative displacement of each node pair along t and b,

    u_t = R_t q + R_t_next q_next,    u_b = R_b q + R_b_next q_next,

q_next the next sector's coordinates (in the cyclic reduction q shifted in time by
the inter-sector phase), the maps of `contacts.shroud_pair_maps(plane=True)`: the
same pairing of the faces and the same turn of the neighbour's vector by the pitch
as the elements that are solved."""
from __future__ import annotations

import numpy as np

from .contacts import ShroudPair, shroud_pair_maps
from .blade_cache import blade_model, case_speed, sector_map


def free_pairs(scene) -> list:
    """[(index in scene.contacts, ShroudPair)] of the scene's 1D shroud pairs."""
    return [(i, c) for i, c in enumerate(getattr(scene, "contacts", ()))
            if isinstance(c, ShroudPair) and c.friction == "1d"]


def plane_rows(scene, case: dict | None = None) -> dict:
    """{contact index: (own, next)} of the scene's 1D shroud pairs (`free_pairs`),
    own and next (2, k, n) dense [-]: rows along t (0) and b = n x t (1) of the pair's
    k node pairs over the n coordinates of a case's system (module doc).  Empty for a
    scene that is not a tuned cyclic FE blade (a mistuned disk's full assembly is not
    mapped here)."""
    if not free_pairs(scene) or not scene.cyclic or scene.mistuning is not None:
        return {}
    speed = case_speed(scene.structure, case)
    return {i: pair_rows(scene.structure, scene.reduction, pair, speed)
            for i, pair in free_pairs(scene)}


def pair_rows(structure, reduction, pair: ShroudPair, speed: float) -> tuple:
    """(own, next) of one pair (`plane_rows`), reduced as the case's system is."""
    blade = blade_model(structure)
    own, nxt = shroud_pair_maps(blade, pair, structure.disk, plane=True)
    if reduction is None:
        reduce = (lambda B: B.toarray())
    else:
        reduce = (lambda B: sector_map(structure, reduction, speed, B))
    return (np.stack([reduce(B) for B in own[:2]]), np.stack([reduce(B) for B in nxt[:2]]))
