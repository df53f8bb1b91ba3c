"""Study files -> validated studies: read, decode, parse TOML, and hand the document
to the parser of its kind (the registry `kinds.KINDS`: response, modes of a blade or
of a disk, accuracy-cost).  Every problem is one `UsageError("<file>: <field>: <what>")`.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np

from ...errors import UsageError
from .validation import Checker
from ..kinds import kind_of_document
from .study_types import Study, content_bytes


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
    returns): a `study_types.Study`, a `study_types.ModesStudy`, a disk modes or an accuracy-cost
    study, as its kind reads it (`kinds.kind_of_document`)."""
    Checker(file).table(data, "(document)")
    return kind_of_document(data, file).parse(data, file=file, name=name, text=text, quick=quick)


def study_to_mapping(study: Study) -> dict:
    """The canonical document of a validated study: explicit M, C, K, coefficient
    rows for contacts, every default spelt out, no [quick] table (the variant that
    was loaded).  `study_from_mapping(study_to_mapping(s))` rebuilds the same study."""
    sc = study.scene
    cdofs = sc.contact_dofs  # disk scenes: also next.<dof>

    def row(r):
        return {d: float(c) for d, c in zip(cdofs, r) if c != 0}

    contacts = []
    for c in sc.contacts:
        e = {"name": c.name, "tangential": row(c.bt), "ku": c.ku, "kv": c.kv, "mu": c.mu}
        if np.any(c.bn):
            e["normal"] = row(c.bn)
        if c.n0 is not None:
            e["n0"] = c.n0
        contacts.append(e)
    sector_dofs = sc.sector_dofs  # disk scenes: the sector's names
    forcing = sc.loads[0].amplitudes
    excitation = [{"dof": sector_dofs[j], "amplitude": float(abs(F)) if h else float(F.real),
                   "harmonic": int(h), "phase": float(np.angle(F)) if h else 0.0}
                  for j, h in zip(*np.nonzero(forcing)) for F in [forcing[j, h]]]
    fr = study.sweep.frequency
    sweep = {a: list(v) for a, v in study.sweep.axes.items()}
    sweep["frequency"] = {"start": fr.start, "stop": fr.stop, "unit": fr.unit}
    solver = {k: v for k, v in vars(study.solver).items() if v is not None}
    out = study.output
    output = {"dofs": list(out.dofs), "figures": list(out.figures), "yscale": out.yscale,
              "peak_windows": [list(w) for w in out.peak_windows]}
    if out.optimum is not None:
        o = out.optimum
        output["optimum_preload"] = {"dof": o["dof"], "bounds": list(o["bounds"]), "rtol": o["rtol"]}
        if o["window"] is not None:
            w = o["window"]
            output["optimum_preload"]["frequency"] = {"start": w.start, "stop": w.stop, "unit": w.unit}
    scene = {"model": sc.model, "effects": list(sc.effects), "dofs": list(sector_dofs),
             "matrices": {k: getattr(sc.structure, k).tolist() for k in ("M", "C", "K")},
             "contact": contacts, "excitation": excitation}
    if sc.model == "disk":
        scene["disk"] = {"sectors": sc.assembly.sectors}
        if sc.assembly.engine_order is not None:
            scene["disk"]["engine_order"] = sc.assembly.engine_order
        if sc.assembly.springs:
            scene["disk"]["spring"] = [{"name": s.name, "elongation": row(s.row), "k": s.k}
                                       for s in sc.assembly.springs]
        if sc.mistuning is not None and sc.mistuning.factors is not None:
            scene["disk"]["mistuning"] = {"factors": list(sc.mistuning.factors)}
        elif sc.mistuning is not None:
            mis = {"stiffness_std": sc.mistuning.stiffness_std}
            if sc.mistuning.seed is not None:
                mis["seed"] = sc.mistuning.seed
            scene["disk"]["mistuning"] = mis
    return {
        "study": {"title": study.title, "description": study.description,
                  "reference": study.reference},
        "scene": scene,
        "sweep": sweep,
        "solver": solver,
        "output": output,
    }
