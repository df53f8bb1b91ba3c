"""The parts every study document shares, read the same way for every kind: the
`[study]` header and the `[quick]` overlay.

    [study] title = "..."  description = "..."  reference = "..."  kind = "..."

`kind` names the study kind (`kinds.KINDS`); the registry reads and checks it before
the kind's parser runs, the header parser only allows the key.

`[quick]` holds overrides of the main tables, read only when the quick variant is
asked for (`--quick`): a full run never depends on it.  `[quick.<table>]` lies over
`[<table>]` key by key: a key of a sub-table listed as `deep` (e.g. `reference` of
an accuracy case, `blade` of a blade scene) is merged key by key again, every other
key is replaced.  Every failure names the field it came from (`quick.<table>.<key>`
for an override).
"""
from __future__ import annotations

import re

HEADER_KEYS = ("title", "description", "reference", "kind")


def parse_header(ck, data) -> dict:
    """{title, description, reference} of the `[study]` table of `data` (failures
    through the `Checker` ck: a missing title, an unknown key, a value not a string)."""
    head = ck.table(data["study"], "study")
    ck.keys(head, "study", HEADER_KEYS, required=("title",))
    return {"title": ck.string(head["title"], "study.title"),
            "description": ck.string(head.get("description", ""), "study.description"),
            "reference": ck.string(head.get("reference", ""), "study.reference")}


def quick_tables(ck, data, quick: bool, allowed) -> dict:
    """{table: [quick.<table>]} of a --quick load, each a table, its names among
    `allowed` ({} when `quick` is false: the [quick] table is not read at all)."""
    if not quick:
        return {}
    qt = ck.table(data.get("quick"), "quick", required=False)
    ck.keys(qt, "quick", tuple(allowed))
    return {k: ck.table(v, f"quick.{k}") for k, v in qt.items()}


def overlay(ck, base: dict, quick: dict, path: str, deep=()) -> tuple:
    """(merged table, where) of `[quick.<path>]` (the dict `quick`) over `[<path>]`
    (`base`): the keys of `deep` merged key by key, every other key replaced.
    `where(p)` is the field of the dotted path p inside the table, list indices
    included: `quick.<path>.<p>` if its value came from the quick table, else `<path>.<p>`."""
    merged, from_quick = dict(base), set()
    for k, v in quick.items():
        if k in deep:
            sub = ck.table(v, f"quick.{path}.{k}")
            merged[k] = {**ck.table(base.get(k, {}), f"{path}.{k}"), **sub}
            from_quick |= {f"{k}.{s}" for s in sub}
        else:
            merged[k] = v
            from_quick.add(k)

    def where(p: str) -> str:
        parts = re.sub(r"\[[^\]]*\]", "", p).split(".")
        heads = {".".join(parts[:i]) for i in range(1, len(parts) + 1)}
        return f"quick.{path}.{p}" if heads & from_quick else f"{path}.{p}"

    return merged, where
