"""Study-file keys of the contact laws besides Yang-Menq (`contact.registry`).

A lumped scene places the elements of a registered law with an array of tables
named by the law (`study_table`): per element an optional name, one signed DOF list
per direction (`study_rows`, e.g. `dofs = ["x1", "-x2"]`: u = x1 - x2; one DOF:
against ground) and the law's numbers (`study_keys`); it declares the law's effect
in `[scene] effects` exactly when it has some.  The law's module documents its keys.
"""
from __future__ import annotations

from ...contact.laws import LawElements
from ...contact.registry import study_laws
from ...solve.stability.methods import require_mode
from ..files.study_types import NAME_PATTERN


def law_tables(ck, tab, dofs, effects, disk, signed_row) -> tuple:
    """`[[scene.<table>]]` of every registered contact law besides Yang-Menq
    (`contact.registry`): per element a name, one signed DOF list per direction
    (`study_rows`) and the law's numbers (`study_keys`), as `LawElements` with one
    element each (`signed_row(ck, value, field, dofs, required)` reads a DOF list as
    the lumped parser does).  A scene has such elements exactly when it declares the
    law's effect."""
    out = []
    for table, cls in study_laws().items():
        f = f"scene.{table}"
        raw = tab.get(table, [])
        if isinstance(raw, dict):
            ck.fail(f, f"must be an array of tables: write [[scene.{table}]]")
        items = ck.array(raw, f, min_length=0)
        if items and disk:
            ck.fail(f, f"a {cls.name} acts on one structure: not in a disk scene")
        check_law_effects(ck, {table: bool(items)}, effects)
        for i, c in enumerate(items):
            fi = f"{f}[{i}]"
            c = ck.table(c, fi)
            keys = tuple(cls.study_rows) + tuple(cls.study_keys)
            needed = tuple(cls.study_rows) + tuple(k for k, (_, d) in cls.study_keys.items()
                                                   if d is None)
            ck.keys(c, fi, ("name",) + keys, required=needed)
            ck.string(c.get("name", f"{table}{i}"), f"{fi}.name", pattern=NAME_PATTERN)
            rows = tuple(signed_row(ck, c[r], f"{fi}.{r}", dofs, True)[None, :]
                         for r in cls.study_rows)
            # a default naming another key takes that key's value (ku2 = ku)
            values = {k: ck.number(c.get(k, c.get(d) if isinstance(d, str) else d), f"{fi}.{k}")
                      for k, (_, d) in cls.study_keys.items()}
            try:
                out.append(LawElements(cls.from_study(values), rows))
            except ValueError as exc:
                ck.fail(fi, str(exc))
    return tuple(out)


def check_law_effects(ck, present: dict, effects) -> None:
    """A scene declares a law's effect exactly when it has elements of the law
    (`present`: {study table: whether the scene has some})."""
    laws = study_laws()
    for table, has in present.items():
        if has != (laws[table].effect in effects):
            ck.fail("scene.effects", f"declare \"{laws[table].effect}\" exactly when the scene "
                                     f"has [[scene.{table}]]")


def supported(laws, stability) -> bool:
    """Every law of `laws` (`LawElements`) can be run by the solvers of `stability`."""
    try:
        require_mode(laws, stability)
    except ValueError:
        return False
    return True


def check_law_solvers(ck, laws, stability, field) -> None:
    """Fail at `field` when a solver the stability mode needs cannot evaluate one of
    the scene's laws (`stability.methods.MODE_SOLVERS`; Hill's method serves every law)."""
    try:
        require_mode(laws, stability)
    except ValueError as exc:
        ck.fail(field, f"{exc}; give stability = \"hill\" or false")


def check_law_methods(ck, laws, method: str, field) -> None:
    """Fail at `field` when a law of the scene does not offer the force evaluation
    `method` (the 2D friction law has no closed form: AFT only)."""
    for le in laws:
        offered = getattr(le.law, "methods", None)
        if offered is not None and method not in offered:
            ck.fail(field, f"the contact law {le.law.name!r} is evaluated by "
                           f"{' or '.join(offered)} only: give force_evaluation = "
                           f"\"{offered[0]}\" (and samples)")
