"""The registry of study kinds: the one place a study's kind is dispatched on.

Each kind's module (`execution/<kind>_study`) defines its `study_types.StudyKind`
entry (how a document of it is recognised and read, how `check` describes it with its
cost estimate, how it is estimated and run); `KINDS` lists them, first match first.
`documents` reads a document through `kind_of_document`, `run`, `check` and `bench
estimate` act on a study through `kind_of`.  A new kind is one module and one line
here.

A document names its kind in `[study] kind` (`StudyKind.word`; "modes" is the
modes of a blade or of a disk, told apart by the scene); without it, the first kind
that takes the document by default (`by_default`: a blade scene with a `[modes]`
table is a modes study, anything else a response).
"""
from __future__ import annotations

from .execution import (accuracy_study, disk_modes_study, modes_study, nonlinear_modes_study,
                        response_study)
from .files.validation import Checker

KINDS = (
    accuracy_study.KIND,          # [study] kind = "accuracy_cost"
    disk_modes_study.KIND,        # "modes" of a lumped disk or of FE blades in a disk
    modes_study.KIND,             # "modes" of an FE blade
    nonlinear_modes_study.KIND,   # "nonlinear_modes": backbones, modal damping, synthesis
    response_study.KIND,          # "response" (the default): lumped, disk and blade scenes
)


def stated_kind(ck: Checker, data):
    """The `[study] kind` of a document (None when not given), one of the words of
    `KINDS` (else a failure through ck naming `study.kind`)."""
    head = data.get("study")
    if not isinstance(head, dict) or "kind" not in head:
        return None
    return ck.string(head["kind"], "study.kind", tuple(dict.fromkeys(k.word for k in KINDS)))


def kind_of_document(data, file: str = "<study>"):
    """The `StudyKind` that reads the document `data` (a dict): the first whose word it
    states (or that takes it by default) and whose scene it has."""
    ck = Checker(file)
    word = stated_kind(ck, data)
    for kind in KINDS:
        named = kind.by_default(data) if word is None else word == kind.word
        if named and kind.fits(data):
            return kind
    scene = data.get("scene")
    model = scene.get("model") if isinstance(scene, dict) else None
    ck.fail("study.kind", f"a {word!r} study cannot be made of this scene (scene.model = "
                          f"{model!r})")


def kind_of(study):
    """The `StudyKind` of a validated study (its `kind`)."""
    return next(k for k in KINDS if k.name == study.kind)
