"""Matrices exported by other FE codes (`structure.matrix_files`).

CalculiX itself (`ccx`, Debian package calculix-ccx; the test says why it skips
without it): two C3D8 bricks, `*FREQUENCY, SOLVER=MATRIXSTORAGE`, read back and
compared with scikit-fem's trilinear hexahedra on the same mesh (read from the same
deck through meshio) -- K and M to 1e-12 (ccx writes 14 digits), frequencies to 1e-8.  The other formats:
files written here in each documented layout from known matrices, read back to 1e-14;
a malformed file of each kind is one line naming the file and the place."""
import shutil
import subprocess

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.errors import UsageError
from pipeline.structure.exchange.matrix_files import (read_abaqus, read_ansys, read_calculix,
                                             read_matrix_market)
from helpers import frequencies

DECK = """*NODE, NSET=NALL
1, 0.0, 0.0, 0.0
2, 0.1, 0.0, 0.0
3, 0.1, 0.03, 0.0
4, 0.0, 0.03, 0.0
5, 0.0, 0.0, 0.004
6, 0.1, 0.0, 0.004
7, 0.1, 0.03, 0.004
8, 0.0, 0.03, 0.004
9, 0.2, 0.0, 0.0
10, 0.2, 0.03, 0.0
11, 0.2, 0.0, 0.004
12, 0.2, 0.03, 0.004
*ELEMENT, TYPE=C3D8, ELSET=EALL
1, 1, 2, 3, 4, 5, 6, 7, 8
2, 2, 9, 10, 3, 6, 11, 12, 7
*NSET, NSET=ROOT
1, 4, 5, 8
*MATERIAL, NAME=STEEL
*ELASTIC
2.1e11, 0.3
*DENSITY
7850.
*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL
*BOUNDARY
ROOT, 1, 3
*STEP
*FREQUENCY, SOLVER=MATRIXSTORAGE
*END STEP
"""


def skfem_matrices(deck):
    """K, M of the deck's mesh by scikit-fem (ElementHex1, exact quadrature), DOFs
    (node index, direction) in its own numbering, and the deck's node numbers."""
    import meshio
    from skfem import Basis, BilinearForm, ElementHex1, ElementVector, asm
    from skfem.helpers import dot
    from skfem.io.meshio import from_meshio
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    m = meshio.read(deck, file_format="abaqus")
    mesh = from_meshio(m)
    basis = Basis(mesh, ElementVector(ElementHex1()))
    K = asm(linear_elasticity(*lame_parameters(2.1e11, 0.3)), basis)

    @BilinearForm
    def mass(u, v, w):
        return 7850.0 * dot(u, v)

    return K, asm(mass, basis), basis.nodal_dofs


@pytest.mark.skipif(shutil.which("ccx") is None,
                    reason="CalculiX (ccx) is not installed: apt-get install calculix-ccx")
def test_calculix_export_equals_scikit_fem_on_the_same_mesh(tmp_path):
    deck = tmp_path / "bricks.inp"
    deck.write_text(DECK)
    run = subprocess.run(["ccx", "-i", "bricks"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stdout[-500:]
    ex = read_calculix(tmp_path / "bricks")
    assert ex.n_dof == 24 and ex.dofs[0] == (2, 1)        # nodes 1, 4, 5, 8 fixed
    K, M, nodal = skfem_matrices(deck)
    rows = [nodal[d - 1, node - 1] for node, d in ex.dofs]   # deck node k is point k - 1
    Ks, Ms = K[rows][:, rows].toarray(), M[rows][:, rows].toarray()
    assert np.abs(ex.K.toarray() - Ks).max() <= 1e-12 * np.abs(Ks).max()
    assert np.abs(ex.M.toarray() - Ms).max() <= 1e-12 * np.abs(Ms).max()
    f_ccx, f_ref = frequencies(ex.K.toarray(), ex.M.toarray()), frequencies(Ks, Ms)
    # ccx writes 14 significant digits: the thin brick's bending mode, 650 times below
    # the highest, moves by up to ~1e-14 (f_max / f_min)^2 ~ 4e-9 (measured 2.3e-10)
    assert np.abs(f_ccx / f_ref - 1).max() < 1e-8


# --------------------------------------------------------------------------- other formats
rng = np.random.default_rng(7)
N = 7
DOFS = [(3, 1), (3, 2), (3, 3), (4, 1), (4, 2), (4, 3), (9, 6)]
A = rng.standard_normal((N, N))
K_REF = A @ A.T * 1e7 + np.eye(N) * 1e6
M_REF = np.diag(rng.uniform(0.1, 1.0, N))
M_REF[0, 3] = M_REF[3, 0] = 0.01


def write_calculix(stem, K, M, dofs):
    for suffix, A_ in ((".sti", K), (".mas", M)):
        lines = [f"{i + 1} {j + 1} {A_[i, j]:.17e}" for j in range(N) for i in range(j + 1)]
        stem.with_suffix(suffix).write_text("\n".join(lines) + "\n")
    stem.with_suffix(".dof").write_text("\n".join(f"{n}.{d}" for n, d in dofs) + "\n")


def write_abaqus(path, A_, dofs):
    lines = ["** written by the test"] + [
        f"{dofs[i][0]}, {dofs[i][1]}, {dofs[j][0]}, {dofs[j][1]}, {A_[i, j]:.17e}"
        for i in range(N) for j in range(i + 1) if A_[i, j] != 0.0]
    path.write_text("\n".join(lines) + "\n")


def write_hb_rsa(path, A_):
    """An RSA Harwell-Boeing file of the lower triangle by columns."""
    L = sp.csc_matrix(np.tril(A_))
    ptr, ind, val = L.indptr + 1, L.indices + 1, L.data
    chunk = lambda xs, per, fmt: ["".join(fmt.format(x) for x in xs[k:k + per])  # noqa: E731
                                  for k in range(0, len(xs), per)]
    p, i, v = chunk(ptr, 10, "{:8d}"), chunk(ind, 10, "{:8d}"), chunk(val, 3, "{:25.17E}")
    head = [f"{'test matrix':<72}{'KEY':<8}",
            f"{len(p) + len(i) + len(v):14d}{len(p):14d}{len(i):14d}{len(v):14d}{0:14d}",
            f"{'RSA':<14}{N:14d}{N:14d}{len(val):14d}{0:14d}",
            f"{'(10I8)':<16}{'(10I8)':<16}{'(3E25.17)':<20}{'':<20}"]
    path.write_text("\n".join(head + p + i + v) + "\n")


def write_mapping(path, dofs):
    labels = {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}
    path.write_text("Matrix Eqn   Node   DOF\n" + "".join(
        f"{k + 1:10d}{n:10d}   {labels[d]}\n" for k, (n, d) in enumerate(dofs)))


def assert_same(ex, dofs=DOFS):
    order = [dofs.index(d) for d in ex.dofs]
    Kr, Mr = K_REF[np.ix_(order, order)], M_REF[np.ix_(order, order)]
    assert sorted(ex.dofs) == sorted(dofs)
    assert np.abs(ex.K.toarray() - Kr).max() <= 1e-14 * np.abs(Kr).max()
    assert np.abs(ex.M.toarray() - Mr).max() <= 1e-14 * np.abs(Mr).max()


def test_calculix_files_round_trip(tmp_path):
    write_calculix(tmp_path / "job", K_REF, M_REF, DOFS)
    ex = read_calculix(tmp_path / "job.sti")
    assert list(ex.dofs) == DOFS
    assert_same(ex)


def test_a_calculix_job_named_with_a_dot_keeps_its_name(tmp_path):
    """Job "blade.v2" has files blade.v2.sti, .mas, .dof: its dot is not a suffix."""
    job = tmp_path / "blade.v2"
    for suffix, A_ in ((".sti", K_REF), (".mas", M_REF)):
        write_calculix(tmp_path / "x", A_, A_, DOFS)
        (tmp_path / "x.sti").rename(tmp_path / f"blade.v2{suffix}")
    (tmp_path / "x.dof").rename(tmp_path / "blade.v2.dof")
    for given in (job, tmp_path / "blade.v2.mas"):
        ex = read_calculix(given)
        assert list(ex.dofs) == DOFS
        assert_same(ex)


def test_abaqus_files_round_trip(tmp_path):
    write_abaqus(tmp_path / "k.mtx", K_REF, DOFS)
    write_abaqus(tmp_path / "m.mtx", M_REF, DOFS)
    assert_same(read_abaqus(tmp_path / "k.mtx", tmp_path / "m.mtx"))


def test_ansys_files_round_trip(tmp_path):
    write_hb_rsa(tmp_path / "k.hb", K_REF)
    write_hb_rsa(tmp_path / "m.hb", M_REF)
    write_mapping(tmp_path / "k.mapping", DOFS)
    ex = read_ansys(tmp_path / "k.hb", tmp_path / "m.hb", tmp_path / "k.mapping")
    assert list(ex.dofs) == DOFS
    assert_same(ex)


def test_matrix_market_files_round_trip(tmp_path):
    import scipy.io
    scipy.io.mmwrite(tmp_path / "k.mtx", sp.coo_matrix(K_REF), symmetry="symmetric",
                     precision=17)
    scipy.io.mmwrite(tmp_path / "m.mtx", sp.coo_matrix(M_REF), precision=17)
    (tmp_path / "dofs.txt").write_text("# node direction\n" +
                                       "".join(f"{n} {d}\n" for n, d in DOFS))
    ex = read_matrix_market(tmp_path / "k.mtx", tmp_path / "m.mtx", tmp_path / "dofs.txt")
    assert list(ex.dofs) == DOFS
    assert_same(ex)


def one_line(exc_info, path, where):
    msg = str(exc_info.value)
    assert msg.startswith(f"{path}: {where}") and "\n" not in msg, msg


def test_malformed_files_are_one_line_naming_file_and_place(tmp_path):
    write_calculix(tmp_path / "job", K_REF, M_REF, DOFS)
    dof = tmp_path / "job.dof"
    dof.write_text("\n".join(f"{n}.{d}" for n, d in DOFS[:-1]) + "\n")   # one DOF short
    with pytest.raises(UsageError) as e:
        read_calculix(tmp_path / "job")
    one_line(e, tmp_path / "job.sti", "size")
    dof.write_text("3.1\n3.x\n")
    with pytest.raises(UsageError) as e:
        read_calculix(tmp_path / "job")
    one_line(e, dof, "line 2")
    write_abaqus(tmp_path / "k.mtx", K_REF, DOFS)
    bad = tmp_path / "k.mtx"
    bad.write_text(bad.read_text() + f"{DOFS[0][0]}, {DOFS[0][1]}, {DOFS[1][0]}, "
                                      f"{DOFS[1][1]}, 1.0\n")   # (i, j) contradicts (j, i)
    with pytest.raises(UsageError) as e:
        read_abaqus(bad, bad)
    one_line(e, bad, "symmetry")
    write_hb_rsa(tmp_path / "k.hb", K_REF)
    write_mapping(tmp_path / "k.mapping", DOFS[:-1])
    with pytest.raises(UsageError) as e:
        read_ansys(tmp_path / "k.hb", tmp_path / "k.hb", tmp_path / "k.mapping")
    one_line(e, tmp_path / "k.hb", "size")
    with pytest.raises(UsageError) as e:
        read_matrix_market(tmp_path / "none.mtx", tmp_path / "none.mtx", tmp_path / "k.mapping")
    one_line(e, tmp_path / "k.mapping", "line 1")


def test_a_calculix_file_cut_short_is_named_truncated(tmp_path):
    """The .sti of the 7 x 7 K_REF (28 entries, column by column) cut after column 6
    (line 21), and in the middle of line 22: each named where it ends, 'truncated?'
    -- not read as a K with an empty last row (singular), unless read as a damping
    matrix, which may have one."""
    write_calculix(tmp_path / "job", K_REF, M_REF, DOFS)
    sti = tmp_path / "job.sti"
    lines = sti.read_text().splitlines(keepends=True)
    assert len(lines) == 28
    sti.write_text("".join(lines[:21]))
    with pytest.raises(UsageError, match=r"job\.sti: ends at line 21: its last row is 6, but "
                                         r"\S*job\.dof maps 7 rows: truncated\?$") as e:
        read_calculix(tmp_path / "job")
    one_line(e, sti, "ends at line 21")
    # a damping matrix may leave DOFs out: read so, the last row and column are zero
    C = read_calculix(tmp_path / "job", complete=False).K.toarray()
    assert not C[6].any() and not C[:, 6].any()
    assert np.abs(C[:6, :6] - K_REF[:6, :6]).max() <= 1e-14 * np.abs(K_REF).max()
    sti.write_text("".join(lines[:21]) + lines[21][:4])
    with pytest.raises(UsageError, match=r"expected 3 numbers, got '1 7' \(the last line: "
                                         r"the file truncated\?\)") as e:
        read_calculix(tmp_path / "job")
    one_line(e, sti, "line 22")


def test_abaqus_and_harwell_boeing_files_cut_short_are_named_truncated(tmp_path):
    """An Abaqus stiffness file without its entries of the last node (9, dof 6) beside a
    whole mass file; a Harwell-Boeing file without its last line of values."""
    write_abaqus(tmp_path / "k.mtx", K_REF, DOFS)
    write_abaqus(tmp_path / "m.mtx", M_REF, DOFS)
    k = tmp_path / "k.mtx"
    lines = [x for x in k.read_text().splitlines() if not x.startswith("9, 6")]
    k.write_text("\n".join(lines) + "\n")
    with pytest.raises(UsageError, match=r"its last row is node 4 dof 3, but \S*m\.mtx goes on "
                                         r"to node 9 dof 6: truncated\?$") as e:
        read_abaqus(k, tmp_path / "m.mtx")
    one_line(e, k, f"ends at line {len(lines)}")
    write_hb_rsa(tmp_path / "k.hb", K_REF)
    hb = tmp_path / "k.hb"
    hb.write_text("\n".join(hb.read_text().splitlines()[:-1]) + "\n")
    write_mapping(tmp_path / "k.mapping", DOFS)
    with pytest.raises(UsageError, match=r"found \d+: the file cut short \(truncated\?\)") as e:
        read_ansys(hb, hb, tmp_path / "k.mapping")
    one_line(e, hb, "values")
