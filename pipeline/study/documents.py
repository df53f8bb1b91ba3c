"""Study files -> validated studies: read, decode, parse TOML, and hand the document
to the parser of its kind (the registry `KINDS`): an accuracy-cost study
(`accuracy_cost`), an FE blade scene (`blade_scene`: response or modes), or a lumped
or disk scene (`scene`).  Every problem is one `UsageError("<file>: <field>: <what>")`.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

from ..errors import UsageError
from . import accuracy_cost, blade_scene, scene
from .checker import Checker
from .spec import Study


def load_study(path, quick: bool = False) -> Study:
    """Read, parse and validate a study file (UsageError on any problem).

    Both the full study and its `[quick]` variant are validated; `quick` selects
    which one is returned.
    """
    path = Path(path)
    file = str(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise UsageError(f"{file}: (file): no such file") from None
    except OSError as exc:
        raise UsageError(f"{file}: (file): cannot read: {exc.strerror or exc}") from None
    return parse_study(raw, file=file, name=path.stem, quick=quick)


def parse_study(text, file: str = "<study>", name: str | None = None, quick: bool = False) -> Study:
    """Parse study text (str or UTF-8 bytes) and validate it."""
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise UsageError(f"{file}: (file): not UTF-8 text (byte 0x{text[exc.start]:02x} "
                             f"at offset {exc.start})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        where = f"line {m.group(1)}" if m else "(syntax)"
        what = re.sub(r"\s*\(at (line \d+, column \d+|end of document)\)", "", msg)
        raise UsageError(f"{file}: {where}: TOML syntax: {what}") from None
    except (ValueError, RecursionError) as exc:  # e.g. absurdly nested or huge input
        raise UsageError(f"{file}: (syntax): cannot parse: {type(exc).__name__}") from None
    if name is None:
        name = Path(file).stem
    return study_from_document(data, file=file, name=name, text=text, quick=quick)


def is_accuracy_document(data) -> bool:
    head = data.get("study")
    return isinstance(head, dict) and head.get("kind") == "accuracy_cost"


# study kinds: (recognises a document, validates it); the first match parses it
KINDS = ((is_accuracy_document, accuracy_cost.study_from_mapping),
         (blade_scene.is_blade_document, blade_scene.study_from_mapping),
         (lambda data: True, scene.study_from_mapping))


def study_from_document(data, *, file: str = "<study>", name: str = "study", text: str = "",
                        quick: bool = False):
    """Validate an already-parsed study document of any kind (the dict `tomllib`
    returns): a `spec.Study`, a `spec.ModesStudy` or an accuracy-cost study."""
    Checker(file).table(data, "(document)")
    parse = next(parse for recognises, parse in KINDS if recognises(data))
    return parse(data, file=file, name=name, text=text, quick=quick)
