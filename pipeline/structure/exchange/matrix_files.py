"""A structure exported by another FE code: its stiffness and mass matrices and the
map from their rows to (node, direction), read from the files the codes write.

    CalculiX   `*FREQUENCY, SOLVER=MATRIXSTORAGE`: `<job>.sti`, `<job>.mas` (one
               triangle, "i j value", 1-based) and `<job>.dof` ("node.direction" per
               equation; constrained DOFs are absent)              `read_calculix`
    Abaqus     `*MATRIX GENERATE` / `*MATRIX OUTPUT, FORMAT=COORDINATE`: `.mtx` lines
               "node, dof, node, dof, value" (one triangle or both)   `read_abaqus`
    ANSYS      `HBMAT`: Harwell-Boeing files (RSA: the lower triangle by columns,
               or RUA) and the `.mapping` file ("equation node label", labels UX ...
               ROTZ)                                                   `read_ansys`
    generic    Matrix Market files (scipy.io.mmread) and a table "node direction"
               per row                                           `read_matrix_market`

Directions are 1, 2, 3 (translations x, y, z) and 4, 5, 6 (rotations).  The matrices
come back as symmetric scipy.sparse CSR matrices in the units of the file (state them
in the study: N/m and kg for SI exports).  Every mistake is one line naming the file
and the place in it (`UsageError`: a line, the size, a DOF map that does not match the
matrix, an entry whose mirror disagrees, a non-finite value, a missing file).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ...errors import UsageError

ANSYS_LABELS = {"UX": 1, "UY": 2, "UZ": 3, "ROTX": 4, "ROTY": 5, "ROTZ": 6}
SYMMETRY_RTOL = 1e-10     # mirror entries given twice must agree to this (of the largest)


@dataclass(frozen=True, eq=False)
class ExportedMatrices:
    """K, M (n, n) symmetric CSR and `dofs`: (node, direction) of each row."""

    K: sp.csr_matrix
    M: sp.csr_matrix
    dofs: tuple
    source: str

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]


def _text(path) -> list:
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"{path}: no such file")
    return path.read_text(errors="replace").splitlines()


def _fail(path, where, what):
    raise UsageError(f"{path}: {where}: {what}")


def symmetric(path, rows, cols, vals, n: int) -> sp.csr_matrix:
    """The symmetric (n, n) matrix of entries given on one triangle or both (0-based
    rows, cols); a mirror pair that disagrees by more than SYMMETRY_RTOL of the largest
    entry, a repeated entry or an index outside 0..n-1 fails naming `path`."""
    rows, cols, vals = (np.asarray(a) for a in (rows, cols, vals))
    if rows.size and (min(rows.min(), cols.min()) < 0 or max(rows.max(), cols.max()) >= n):
        bad = int(np.argmax((rows < 0) | (cols < 0) | (rows >= n) | (cols >= n)))
        _fail(path, "size", f"entry ({rows[bad] + 1}, {cols[bad] + 1}) lies outside the "
                            f"{n} x {n} matrix its DOF map gives")
    if not np.all(np.isfinite(vals)):
        _fail(path, "values", "a value is not finite")
    A = sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
    if A.nnz and sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)).max() > 1:
        _fail(path, "entries", "an entry is given twice")
    lower, upper = sp.tril(A, -1), sp.triu(A, 1).T
    both = lower.multiply(upper != 0)
    if both.nnz:
        scale = max(abs(A).max(), 1e-300)
        diff = abs(both - upper.multiply(lower != 0)).max()
        if diff > SYMMETRY_RTOL * scale:
            _fail(path, "symmetry", f"entries (i, j) and (j, i) differ by {diff:.3g} "
                                    f"({diff / scale:.1e} of the largest entry)")
    off = (lower + upper) - both            # each off-diagonal entry once
    return (sp.diags(A.diagonal()) + off + off.T).tocsr()


def _numbers(path, lines, count: int, kinds, sep=None):
    """Rows of `count` numbers (converters `kinds`) from the non-empty lines; a bad
    last line is named as the end of a file cut short."""
    out = []
    last = max((k for k, line in enumerate(lines, 1) if line.strip()), default=0)
    for k, line in enumerate(lines, 1):
        if not line.strip() or line.lstrip().startswith(("*", "#", "%", "**")):
            continue
        parts = [p for p in (line.split(sep) if sep else line.split()) if p.strip()]
        cut = " (the last line: the file truncated?)" if k == last else ""
        if len(parts) != count:
            _fail(path, f"line {k}", f"expected {count} numbers, got {line.strip()!r}{cut}")
        try:
            out.append([conv(p.strip()) for conv, p in zip(kinds, parts)])
        except ValueError:
            _fail(path, f"line {k}", f"not a number in {line.strip()!r}{cut}")
    return out


def _triplets(path, n: int, dof_file, complete: bool):
    """The symmetric matrix of a CalculiX "i j value" file of `n` rows (`dof_file`
    maps them); when `complete`, a file whose entries stop short of row n was cut
    short."""
    lines = _text(path)
    rows = _numbers(path, lines, 3, (int, int, float))
    if not rows:
        _fail(path, "entries", "no matrix entries")
    i, j, v = (np.array(c) for c in zip(*rows))
    last = int(max(i.max(), j.max()))
    if complete and last < n:
        _fail(path, f"ends at line {len(lines)}", f"its last row is {last}, but {dof_file} "
                                                  f"maps {n} rows: truncated?")
    return symmetric(path, i - 1, j - 1, v, n)


JOB_SUFFIXES = (".sti", ".mas", ".dof", ".inp")


def calculix_file(job, suffix: str) -> Path:
    """The file `<job><suffix>` of a CalculiX job, `job` given with or without one of
    its files' suffixes (a job named "blade.v2" keeps its dot: "blade.v2.sti")."""
    job = Path(job)
    if job.suffix in JOB_SUFFIXES:
        job = job.with_suffix("")
    return job.parent / (job.name + suffix)


def read_calculix(stem, complete: bool = True) -> ExportedMatrices:
    """`<stem>.sti`, `<stem>.mas` and `<stem>.dof` of a CalculiX
    `*FREQUENCY, SOLVER=MATRIXSTORAGE` step (`stem` with or without a suffix).
    `complete`: every row has entries (a stiffness, a mass; not a damping matrix,
    which may leave DOFs out), else the file was cut short."""
    dof_file = calculix_file(stem, ".dof")
    stem = dof_file.with_suffix("")
    dofs = []
    for k, line in enumerate(_text(dof_file), 1):
        if not line.strip():
            continue
        m = re.fullmatch(r"\s*(\d+)\.(\d)\s*", line)
        if not m or not 1 <= int(m.group(2)) <= 6:
            _fail(dof_file, f"line {k}", f"expected node.direction (direction 1-6), got "
                                         f"{line.strip()!r}")
        dofs.append((int(m.group(1)), int(m.group(2))))
    n = len(dofs)
    if n == 0:
        _fail(dof_file, "entries", "no DOF")
    K = _triplets(calculix_file(stem, ".sti"), n, dof_file, complete)
    M = _triplets(calculix_file(stem, ".mas"), n, dof_file, complete)
    return ExportedMatrices(K, M, tuple(dofs), f"calculix:{stem}")


def read_abaqus(stiffness, mass, complete: bool = True) -> ExportedMatrices:
    """Abaqus `*MATRIX OUTPUT, FORMAT=COORDINATE` files of the stiffness and the mass:
    lines "row node, row dof, column node, column dof, value"; the rows are the (node,
    dof) pairs the files name, in ascending order.  `complete`: as `read_calculix`'s
    (a file that stops before the other's last pair was cut short)."""
    data, length = {}, {}
    for path in (stiffness, mass):
        lines = _text(path)
        data[path], length[path] = _numbers(path, lines, 5, (int, int, int, int, float),
                                            sep=","), len(lines)
        if not data[path]:
            _fail(path, "entries", "no matrix entries")
    pairs = sorted({(int(r[a]), int(r[a + 1])) for rows in data.values() for r in rows
                    for a in (0, 2)})
    for path, rows in data.items():       # rows come in ascending order: a cut file's stop
        last = max((int(r[a]), int(r[a + 1])) for r in rows for a in (0, 2))
        if complete and last < pairs[-1]:
            other = mass if path == stiffness else stiffness
            _fail(path, f"ends at line {length[path]}", f"its last row is node {last[0]} dof "
                  f"{last[1]}, but {other} goes on to node {pairs[-1][0]} dof "
                  f"{pairs[-1][1]}: truncated?")
    for path, rows in data.items():
        bad = [p for p in pairs if not 1 <= p[1] <= 6]
        if bad:
            _fail(path, "dof", f"direction {bad[0][1]} of node {bad[0][0]} is not 1-6")
    index = {p: k for k, p in enumerate(pairs)}
    K, M = (symmetric(path, [index[(r[0], r[1])] for r in rows],
                      [index[(r[2], r[3])] for r in rows], [r[4] for r in rows], len(pairs))
            for path, rows in data.items())
    return ExportedMatrices(K, M, tuple(pairs), f"abaqus:{stiffness}")


def _fortran_width(fmt: str, path, where) -> int:
    """The field width of a Fortran format such as (16I5), (1P,4E20.12), (5D16.8)."""
    m = re.search(r"(\d*)\s*[IEDFG](\d+)", fmt.upper().replace(" ", ""))
    if not m:
        _fail(path, where, f"unreadable Fortran format {fmt.strip()!r}")
    return int(m.group(2))


def _fixed(lines, width: int, count: int, conv, path, where):
    out = []
    for line in lines:
        line = line.rstrip("\n")
        out += [line[k:k + width] for k in range(0, len(line), width)
                if line[k:k + width].strip()]
    if len(out) < count:
        _fail(path, where, f"expected {count} numbers, found {len(out)}: the file cut short "
                           "(truncated?)")
    try:
        return np.array([conv(x.strip().replace("D", "E").replace("d", "e"))
                         for x in out[:count]])
    except ValueError:
        _fail(path, where, "not a number")


def read_harwell_boeing(path) -> sp.csr_matrix:
    """A Harwell-Boeing file (real, assembled: RSA symmetric with its lower triangle by
    columns, or RUA), read from its own header's counts and Fortran formats."""
    lines = _text(path)
    if len(lines) < 4:
        _fail(path, "header", "fewer than four header lines")
    try:
        ptrcrd, indcrd, valcrd, rhscrd = (int(x) for x in lines[1].split()[1:5])
        mxtype = lines[2][:3].upper()
        nrow, ncol, nnz = (int(x) for x in lines[2][3:].split()[:3])
    except ValueError:
        _fail(path, "header", "unreadable counts in lines 2-3")
    if mxtype not in ("RSA", "RUA"):
        _fail(path, "header", f"matrix type {mxtype!r}: only real assembled RSA or RUA")
    if nrow != ncol:
        _fail(path, "header", f"a {nrow} x {ncol} matrix is not square")
    fmts = re.findall(r"\([^)]*\)", lines[3])
    if len(fmts) < 3:
        _fail(path, "header", "line 4 does not give the three Fortran formats")
    start = 4 + (1 if rhscrd > 0 else 0)
    blocks = (lines[start:start + ptrcrd], lines[start + ptrcrd:start + ptrcrd + indcrd],
              lines[start + ptrcrd + indcrd:start + ptrcrd + indcrd + valcrd])
    ptr = _fixed(blocks[0], _fortran_width(fmts[0], path, "pointers"), ncol + 1, int, path,
                 "pointers")
    ind = _fixed(blocks[1], _fortran_width(fmts[1], path, "indices"), nnz, int, path,
                 "indices")
    val = _fixed(blocks[2], _fortran_width(fmts[2], path, "values"), nnz, float, path,
                 "values")
    if ptr[0] != 1 or ptr[-1] != nnz + 1 or np.any(np.diff(ptr) < 0):
        _fail(path, "pointers", "column pointers must rise from 1 to nnz + 1")
    cols = np.repeat(np.arange(ncol), np.diff(ptr))
    if mxtype == "RUA":
        return symmetric(path, ind - 1, cols, val, nrow)
    if np.any(ind - 1 < cols):
        _fail(path, "indices", "an RSA file holds the lower triangle (row >= column)")
    return symmetric(path, ind - 1, cols, val, nrow)


def read_ansys(stiffness, mass, mapping) -> ExportedMatrices:
    """ANSYS `HBMAT` Harwell-Boeing files of the stiffness and the mass, and the
    `.mapping` file: per equation "equation node label" (UX, UY, UZ, ROTX, ROTY, ROTZ),
    equations 1..n."""
    dofs = {}
    for k, line in enumerate(_text(mapping), 1):
        parts = line.split()
        if len(parts) != 3 or not parts[0].isdigit():
            continue       # the header line(s)
        eq, node, label = int(parts[0]), parts[1], parts[2].upper()
        if not node.isdigit() or label not in ANSYS_LABELS:
            _fail(mapping, f"line {k}", f"expected 'equation node label' with a label of "
                                        f"{', '.join(ANSYS_LABELS)}, got {line.strip()!r}")
        dofs[eq] = (int(node), ANSYS_LABELS[label])
    n = len(dofs)
    if sorted(dofs) != list(range(1, n + 1)):
        _fail(mapping, "equations", "the equations must be numbered 1 ... n, once each")
    K, M = read_harwell_boeing(stiffness), read_harwell_boeing(mass)
    for path, A in ((stiffness, K), (mass, M)):
        if A.shape[0] != n:
            _fail(path, "size", f"a {A.shape[0]} x {A.shape[0]} matrix, but {mapping} maps "
                                f"{n} equations")
    return ExportedMatrices(K, M, tuple(dofs[k] for k in range(1, n + 1)), f"ansys:{stiffness}")


def read_matrix_market(stiffness, mass, dof_table) -> ExportedMatrices:
    """Matrix Market files of the stiffness and the mass and a table "node direction"
    per row (lines starting with # are comments)."""
    # deferred: scipy.io, only for Matrix Market files
    import scipy.io

    rows = _numbers(dof_table, _text(dof_table), 2, (int, int))
    dofs = tuple((int(a), int(b)) for a, b in rows)
    if not dofs or any(not 1 <= d <= 6 for _, d in dofs):
        _fail(dof_table, "directions", "one 'node direction' row per DOF, direction 1-6")
    out = []
    for path in (stiffness, mass):
        _text(path)
        try:
            A = sp.coo_matrix(scipy.io.mmread(path))
        except (ValueError, IndexError) as exc:
            _fail(path, "format", f"not a Matrix Market file ({exc})")
        if A.shape != (len(dofs), len(dofs)):
            _fail(path, "size", f"a {A.shape[0]} x {A.shape[1]} matrix, but {dof_table} "
                                f"maps {len(dofs)} DOFs")
        out.append(symmetric(path, A.row, A.col, A.data, len(dofs)))
    return ExportedMatrices(out[0], out[1], dofs, f"matrix_market:{stiffness}")
