"""Study files -> validated studies: read, decode, parse TOML, and hand the document
to the parser of its kind (the registry `kinds.KINDS`: response, modes of a blade or
of a disk, accuracy-cost).  Every problem is one `UsageError("<file>: <field>: <what>")`.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

from ...errors import UsageError
from .validation import Checker
from ..kinds import kind_of_document
from .spec import Study, content_bytes


# files mistaken for a study: their first bytes, what they are
BINARY = {b"CDF\x01": "a netCDF dataset", b"CDF\x02": "a netCDF dataset",
          b"CDF\x05": "a netCDF dataset",
          b"\x89HDF\r\n\x1a\n": "a netCDF-4 dataset", b"\x89PNG": "a PNG image",
          b"%PDF": "a PDF document"}


def load_study(path, quick: bool = False) -> Study:
    """Read, parse and validate a study file (UsageError on any problem).

    `quick` selects the variant: the full study (its `[quick]` table not read, so that
    a full run never depends on it; `check` says so) or the `[quick]` variant, its
    tables merged over the full study's and the result validated.
    """
    path = Path(path)
    file = str(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        shipped = Path(__file__).resolve().parents[3] / "studies" / f"{path.name}.toml"
        hint = f" (a shipped study: {shipped})" if not path.suffix and shipped.is_file() else ""
        raise UsageError(f"{file}: (file): no such file{hint}") from None
    except OSError as exc:
        raise UsageError(f"{file}: (file): cannot read: {exc.strerror or exc}") from None
    return parse_study(raw, file=file, name=path.stem, quick=quick)


def parse_study(text, file: str = "<study>", name: str | None = None, quick: bool = False) -> Study:
    """Parse study text (str or UTF-8 bytes) and validate it."""
    if isinstance(text, (bytes, bytearray)):
        for magic, kind in BINARY.items():
            if bytes(text[:len(magic)]) == magic:
                hint = "; `check` reads a dataset" if "dataset" in kind else ""
                raise UsageError(f"{file}: (file): {kind}, not a study file (TOML text){hint}")
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


def text_describes(study) -> bool:
    """Whether `study.text`, parsed as it was loaded (file, name, variant), gives this
    very study: False without a text, or once a field was replaced in Python after
    loading (the text then describes another study)."""
    if not study.text:
        return False
    try:
        again = parse_study(study.text, file=study.file, name=study.name, quick=study.quick)
    except UsageError:
        return False
    mine = content_bytes(study)
    return mine is not None and content_bytes(again) == mine


def study_from_document(data, *, file: str = "<study>", name: str = "study", text: str = "",
                        quick: bool = False):
    """Validate an already-parsed study document of any kind (the dict `tomllib`
    returns): a `spec.Study`, a `spec.ModesStudy`, a disk modes or an accuracy-cost
    study, as its kind reads it (`kinds.kind_of_document`)."""
    Checker(file).table(data, "(document)")
    return kind_of_document(data, file).parse(data, file=file, name=name, text=text, quick=quick)

