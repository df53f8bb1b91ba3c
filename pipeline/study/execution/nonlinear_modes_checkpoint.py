"""The finished cases of a nonlinear modes study on disk, so that an interrupted run resumes.

Each case whose backbone has points is kept as soon as it ends in
`DIR/.<name>.<key>.cases/case-NNNNN.nc` (`execution.checkpoint`: netCDF read as data
only, written atomically): the backbone's points, its wall time, the largest damping
ratio located between them, and where the full harmonic balance was compared, its
curve in `compared-NNNNN.nc` (written before the case, so a kept case is complete).
A rerun computes only the cases not kept; a kept one gets its mode problem and its
synthesis back from the same system and backbone (`nonlinear_modes_study.resumed_case`:
milliseconds, the same numbers). A failed case is not kept: a rerun computes it again.
The key hashes the study (its text, or all its fields) and the pipeline version.
"""
from __future__ import annotations

import hashlib
import logging
import math
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ... import __version__
from ...solve.nonlinear_modes.backbone import Backbone
from ...solve.response.response import ResponseCurve
from .checkpoint import NotACheckpoint, case_file, read, same_case, write
from ..files.study_types import content_bytes

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class KeptCase:
    """What a finished case keeps: its `Backbone`'s fields, the backbone's wall time
    [s], (s, zeta, omega) of the largest damping ratio, and the comparison's wall time
    [s] and error ("" none) and whether a compared curve is kept beside it."""

    s: np.ndarray
    omega: np.ndarray
    zeta: np.ndarray
    Q: np.ndarray
    residual_static: np.ndarray
    residual_harmonic: np.ndarray
    newton_iterations: np.ndarray
    message: str
    time: float
    damping_peak: np.ndarray
    compared: bool = False
    curve_time: float = math.nan
    compare_error: str = ""

    def backbone(self) -> Backbone:
        return Backbone(self.s, self.omega, self.zeta, self.Q, self.residual_static,
                        self.residual_harmonic, self.newton_iterations, self.message)


def modes_checkpoint_dir(study, out_dir) -> Path:
    """`DIR/.<name>.<key>.cases` of a nonlinear modes study."""
    fields = None if study.text else content_bytes(study)
    content = study.text or (hashlib.sha256(fields).hexdigest() if fields is not None
                             else f"not picklable: never reused {uuid.uuid4()}")
    key = hashlib.sha256("\n".join([content, str(study.quick), "nonlinear_modes",
                                    __version__]).encode()).hexdigest()[:16]
    return Path(out_dir) / f".{study.name}.{key}.cases"


def compared_file(cdir: Path, k: int) -> Path:
    return Path(cdir) / f"compared-{k:05d}.nc"


def save_kept(cdir: Path, k: int, case: dict, res: dict) -> bool:
    """Keep case k's result (`nonlinear_modes_study.run_case`); False (logged) if it cannot
    be written: the run goes on, a rerun recomputes that case."""
    bb, curve = res["backbone"], res.get("curve")
    kept = KeptCase(bb.s, bb.omega, bb.zeta, bb.Q, bb.residual_static, bb.residual_harmonic,
                    np.asarray(bb.newton_iterations), bb.message, float(res["time"]),
                    np.asarray(res["damping_peak"], float), curve is not None,
                    float(res.get("curve_time", math.nan)), res.get("compare_error") or "")
    try:
        Path(cdir).mkdir(parents=True, exist_ok=True)
        if curve is not None:
            write(compared_file(cdir, k), curve, case)
        write(case_file(cdir, k), kept, case)
        return True
    except (OSError, TypeError) as exc:
        log.warning("cannot keep case %d on disk (%s); a rerun will recompute it", k, exc)
        return False


def load_kept(cdir: Path, cases) -> dict:
    """{case index: (KeptCase, compared ResponseCurve or None)} of the cases kept in
    `cdir`; a file that is not a complete case of this grid position is ignored (its
    case computed again)."""
    found = {}
    for k, case in enumerate(cases):
        f = case_file(cdir, k)
        if not f.is_file():
            continue
        try:
            kept_case, kept = read(f, KeptCase)
            curve = read(compared_file(cdir, k), ResponseCurve)[1] if kept.compared else None
        except NotACheckpoint as exc:   # corrupt or foreign: recompute that case
            log.warning("ignoring %s (%s); that case is computed again", f, exc)
            continue
        if same_case(kept_case, case):
            found[k] = (kept, curve)
        else:
            log.warning("ignoring %s (a different case); that case is computed again", f)
    return found
