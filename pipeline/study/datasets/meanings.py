"""What a response dataset's sweep axes and natural frequencies mean for the scene they
were computed on: the words differ where the same number means something else.

- `preload` [N]: on lumped scenes the normal preload n0 of every contact element; on FE
  faces (`model.contacts.FaceContact`, `ShroudPair`) the TOTAL normal load of every
  contact face (of each shroud pair), which `model.contacts.contact_elements` shares
  among the face's node elements: equally, n0_k = n0 / (number of nodes), or with
  stiffness = "per_face" in proportion to the node areas, n0_k = n0 a_k / A.
- `natural_frequency_free`, `natural_frequency_stuck`: on a tuned cyclic sector (a disk
  solved on one sector) the eigenvalues of the sector at the case's wave number, the
  nodal diameter ND = EO of the engine-order excitation
  (`model.system.natural_frequencies`); on a mistuned disk those of the whole assembly.
"""
from __future__ import annotations

from ..files.study_types import SWEEP_AXES

_SHARE = {"per_node": "shared equally by its nodes, n0 / (number of nodes) each",
          "per_face": "shared by its nodes in proportion to their areas, n0 a_k / A"}


def sweep_long_name(axis: str, scene) -> str:
    """`long_name` of the sweep axis `axis` of a dataset of `scene`."""
    if axis != "preload":
        return SWEEP_AXES[axis][1]
    shares = {getattr(c, "stiffness", None) for c in getattr(scene, "contacts", ())}
    if shares <= {None}:   # element contacts (lumped scenes, lumped disks)
        return SWEEP_AXES[axis][1]
    if len(shares) == 1 and None not in shares:
        how = _SHARE[shares.pop()]
    else:
        how = ("shared by its nodes: by area where stiffness = \"per_face\", equally "
               "otherwise")
    return f"total normal preload n0 of every contact face, {how}"


def natural_frequency_comment(scene) -> str | None:
    """`comment` of `natural_frequency_free` / `_stuck` (None: a single structure,
    nothing to add)."""
    if not getattr(scene, "cyclic", False):
        return None
    if scene.mistuning is not None:
        return ("of the whole mistuned assembly (every sector's DOFs): mistuning mixes the "
                "nodal diameters")
    return ("of one sector at nodal diameter ND = EO, the engine order of the case's "
            "excitation (the cyclic sector the case is solved on): the engine-order "
            "family, not the lowest frequencies of the whole disk")


def annotate_natural_frequencies(data_vars: dict, scene) -> None:
    """Add `natural_frequency_comment` to the natural frequencies of `data_vars`
    ({name: (dims, data, attrs)}), where it has something to say."""
    note = natural_frequency_comment(scene)
    for k in ("natural_frequency_free", "natural_frequency_stuck"):
        if note and k in data_vars:
            data_vars[k][2]["comment"] = note
