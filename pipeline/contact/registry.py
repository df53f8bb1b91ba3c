"""The contact laws by name (`contact.laws` describes the interface a law implements).

Each entry names a law class; a class that a lumped study file can place declares
`effect` (the scene effect that switches it on, `[scene] effects`), `study_table`
(its array of tables, `[[scene.<study_table>]]`), `study_rows` (one key per
direction: a signed DOF list, its row of the map) and `study_keys` (key -> (unit,
default: a number, None when required, or another key's name whose value it takes),
and builds one element from those values with
`from_study`.  The Yang-Menq element has its own `[[scene.contact]]`.
"""
from __future__ import annotations

from .cubic_spring import CubicSpring
from .element import YangMenq
from .friction2d.law import Friction2D
from .laws import YangMenqLaw

LAWS = {
    YangMenqLaw.name: YangMenqLaw,
    CubicSpring.name: CubicSpring,
    Friction2D.name: Friction2D,
}


# the law that evaluates each kind of `laws.ContactElements` (a structure's own
# tangential/normal elements)
ELEMENT_LAWS = {YangMenq: YangMenqLaw}


def friction_elements(law: str = "yang_menq", **parameters):
    """The element set (`laws.ContactElements`) of a structure's shroud contacts under
    the law named `law`, from per-element parameters (Yang-Menq: ku, kv [N/m], mu [-],
    n0 [N]; the 2D friction law "friction_2d": the same and ku2 along tangent 2):
    where a scene's declared contacts become elements, so a further law of the
    tangential/normal kind plugs in here."""
    kinds = {YangMenqLaw.name: YangMenq, Friction2D.name: Friction2D}
    if law not in kinds:
        raise ValueError(f"no element set for the contact law {law!r} (known: "
                         f"{', '.join(kinds)})")
    return kinds[law](**parameters)


def law_of(elements):
    """The contact law evaluating `elements` (a `laws.ContactElements`)."""
    try:
        return ELEMENT_LAWS[type(elements)](elements)
    except KeyError:
        raise TypeError(f"no contact law evaluates {type(elements).__name__}") from None


def law_class(name: str):
    """The law class registered as `name`; ValueError listing the known ones."""
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(f"unknown contact law {name!r} (known: {', '.join(LAWS)})") from None


def study_laws() -> dict:
    """{study table name: law class} of the laws a lumped study file can place."""
    return {c.study_table: c for c in LAWS.values() if getattr(c, "study_table", None)}


def law_effects() -> tuple:
    """The scene effects that declare a registered law."""
    return tuple(c.effect for c in LAWS.values() if getattr(c, "effect", None))
