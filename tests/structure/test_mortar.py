"""The dual mortar pairing of faces meshed differently (`structure.mortar`) against the
two-body patch test: two blocks of triquadratic hexahedra meeting on a plane whose
meshes do not match, joined by springs per unit area at the right face's nodes (their
areas int N_k dA), the outer boundary held at a uniform stress state's exact
displacement (normal and tangential stress across the interface, the interface's
uniform opening t / k): the solution is that state to round-off.  Node to segment
misses it; matching meshes give node to node."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, ElementHex2, MeshHex

from pipeline.structure.disk import on_facets
from pipeline.structure.fe_model import BladeParams
from pipeline.structure.mortar import dual_pairing
from pipeline.structure.solid import solid_from_mesh

P = BladeParams(E=2e11, nu=0.3, rho=7800.0)
KP = 1e13        # N/m^3: the interface springs per unit area


def block(x, yz):
    """A block x-range by yz-grid (both axes) and its solid model with its x = 1 face
    (`shroud_right` on the left block, `shroud_left` on the right one)."""
    mesh = MeshHex.init_tensor(np.asarray(x, float), np.asarray(yz, float), np.asarray(yz, float))
    face = "shroud_right" if x[0] < 1 else "shroud_left"
    nodes = np.nonzero(np.isclose(mesh.p[0], 1.0))[0]
    model = solid_from_mesh(mesh, {"root": np.array([], int), face: nodes}, P)
    return mesh, model, model.frames[face]


def patch(yz_left, yz_right, mortar=True):
    """(max |u - u_exact| / max |u_exact| of the two-body patch test (module doc), W)."""
    (ma, A, fa), (mb, B, fb) = block([0.0, 0.5, 1.0], yz_left), block([1.0, 1.5, 2.0], yz_right)
    if mortar:
        W = dual_pairing(fa.points[:, 1:], fa.facets, fb.points[:, 1:], fb.facets)
    else:     # node to segment: each right point on the left facet under it
        Wd = np.zeros((len(fa.points), len(fb.points)))
        for k, (ids, w) in enumerate(on_facets(fa.points, fb.points, fb.facets, 1e-9)):
            Wd[k, ids] = w
        W = sp.csr_matrix(Wd)
    nA, n = A.n_dof, A.n_dof + B.n_dof
    pick = (lambda dofs, off: sp.csr_matrix((np.ones(dofs.size), (np.arange(dofs.size),
                                                                   off + dofs.ravel())),
                                            shape=(dofs.size, n)))
    G = sp.kron(W, sp.identity(3)) @ pick(fb.dofs, nA) - pick(fa.dofs, 0)   # opening
    K = (sp.block_diag([A.K, B.K]) + G.T @ sp.diags(KP * np.repeat(fa.weights, 3)) @ G).tocsr()
    sigma = np.array([[3e7, 1e7, 0.0], [1e7, 0.0, 0.0], [0.0, 0.0, 0.0]])     # Pa
    eps = ((1 + P.nu) * sigma - P.nu * np.trace(sigma) * np.eye(3)) / P.E
    XA, XB = (Basis(m, ElementHex2()).doflocs.T for m in (ma, mb))
    jump = sigma @ [1.0, 0.0, 0.0] / KP      # the springs' opening under the traction
    exact = np.concatenate([(XA @ eps.T).ravel(), (XB @ eps.T + jump).ravel()])
    X = np.vstack([XA, XB])
    outer = np.repeat(np.isclose(X[:, 0], 0.0) | np.isclose(X[:, 0], 2.0)
                      | np.any(np.isclose(X[:, 1:], 0.0) | np.isclose(X[:, 1:], 1.0), axis=1), 3)
    f, d = np.nonzero(~outer)[0], np.nonzero(outer)[0]
    sol = exact.copy()
    sol[f] = spla.spsolve(K[f][:, f].tocsc(), -K[f][:, d] @ exact[d])
    return np.abs(sol - exact).max() / np.abs(exact).max(), W


@pytest.mark.parametrize("yz_left, yz_right", [
    ([0.0, 0.5, 1.0], [0.0, 0.35, 1.0]),
    ([0.0, 0.5, 1.0], [0.0, 0.3, 0.65, 1.0]),
    ([0.0, 0.25, 0.5, 0.75, 1.0], [0.0, 0.4, 1.0])], ids=["2:2", "2:3", "4:2"])
def test_uniform_stress_crosses_faces_meshed_differently_exactly(yz_left, yz_right):
    """Normal (30 MPa) and tangential (10 MPa) stress across the interface: with the dual
    mortar the blocks' displacement is the exact linear field to 1e-12 (measured 2e-15);
    node to segment is off by more than 1e-3 (measured 1.7e-2, 4.9e-2, 4.6e-3)."""
    err, W = patch(yz_left, yz_right)
    assert W is not None and err < 1e-12
    np.testing.assert_allclose(np.asarray(W.sum(axis=1)).ravel(), 1.0, rtol=1e-12)
    assert patch(yz_left, yz_right, mortar=False)[0] > 1e-3


def test_matching_faces_give_node_to_node():
    """Faces meshed alike: the dual mortar's W is the node-to-node pairing to 1e-12 (the
    right point k takes its partner's displacement), and the patch test holds."""
    err, W = patch([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    (_, _, fa), (_, _, fb) = (block([0.0, 0.5, 1.0], [0.0, 0.5, 1.0]),
                              block([1.0, 1.5, 2.0], [0.0, 0.5, 1.0]))
    partner = [int(np.argmin(np.linalg.norm(fb.points - x, axis=1))) for x in fa.points]
    np.testing.assert_allclose(W.toarray(), np.eye(len(fb.points))[partner], atol=1e-12)
    assert err < 1e-12


def test_serendipity_facets_fall_back_to_node_to_segment():
    """8-node facets (their corners carry int N_k dA = -1/3 of a 2 x 2 square): no dual
    basis, None (the caller pairs node to segment); a 9-node facet's areas are the
    Simpson weights 1/9, 4/9, 16/9 and its dual basis is biorthogonal to 1e-12."""
    from pipeline.structure.mortar import dual_weights, square_rule
    from pipeline.structure.facets import shape
    P8 = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [0, -1], [1, 0], [0, 1], [-1, 0]], float)
    assert dual_pairing(P8, [list(range(8))], P8 + 0.1, [list(range(8))]) is None
    A, De = dual_weights("quad9", np.vstack([P8, [[0.0, 0.0]]]))
    np.testing.assert_allclose(De, [1 / 9] * 4 + [4 / 9] * 4 + [16 / 9], rtol=1e-12)
    r, s, w = square_rule()
    N = shape("quad9", r, s)[0]                      # (9, q), the square's Jacobian is 1
    np.testing.assert_allclose((A @ N * w) @ N.T, np.diag(De), atol=1e-12)


def coupled_blocks(n_right):
    """The left block (4 x 4 elements across, 2 along x, clamped at x = 0) and the right
    block (n_right x n_right across) joined at x = 1 by one Yang-Menq element per left-
    block face point (ku = kv = KE a_k / A, mu = 0.3, preload 4 N shared by area; u along
    Y, v = x . (d_left - d_right) closing; along Z a linear spring KE a_k / A), the right
    block loaded by 1 N along Y at its free end's corner: a `System`, Craig-Bampton
    reduced (20 modes; the interface, load and response physical), and the response
    DOF's row."""
    from pipeline.contact import YangMenq
    from pipeline.model.system import System
    from pipeline.structure.reduction import reduce

    (ma, A, fa), (mb, B, fb) = (block([0.0, 0.5, 1.0], np.linspace(0, 1, 5)),
                                block([1.0, 1.5, 2.0], np.linspace(0, 1, n_right + 1)))
    W = dual_pairing(fa.points[:, 1:], fa.facets, fb.points[:, 1:], fb.facets) \
        if n_right != 4 else sp.identity(len(fa.points), format="csr")[
            [int(np.argmin(np.linalg.norm(fb.points - x, axis=1))) for x in fa.points]]
    nA, n = A.n_dof, A.n_dof + B.n_dof
    XA = Basis(ma, ElementHex2()).doflocs.T
    clamp = np.repeat(np.isclose(XA[:, 0], 0.0), 3)
    corner = [nA + int(np.argmin(np.linalg.norm(Basis(mb, ElementHex2()).doflocs.T
                                                - [2.0, 1.0, 1.0], axis=1))) * 3 + 1]
    pick = (lambda dofs, off: sp.csr_matrix((np.ones(dofs.size), (np.arange(dofs.size),
                                                                   off + dofs.ravel())),
                                            shape=(dofs.size, n)))
    rel = pick(fa.dofs, 0) - sp.kron(W, sp.identity(3)) @ pick(fb.dofs, nA)   # left - right
    a = fa.weights / fa.weights.sum()
    KE = 2e9      # N/m, the interface's total stiffness in each direction
    Z = rel[2::3]                                     # along Z: a linear spring, no friction
    K = (sp.block_diag([A.K, B.K]) + Z.T @ sp.diags(KE * a) @ Z).tocsr()
    M = sp.block_diag([A.M, B.M]).tocsr()
    free = np.nonzero(~np.concatenate([clamp, np.zeros(B.n_dof, bool)]))[0]
    iface = np.nonzero(np.asarray(abs(rel).sum(axis=0)).ravel()[free] > 0)[0]
    load = int(np.nonzero(free == corner[0])[0][0])
    red = reduce(K[free][:, free], M[free][:, free], np.r_[iface, load], 20,
                 rayleigh=(0.0, 2e-6))
    T = red.T
    Bt = rel[1::3][:, free] @ T                                   # u along Y
    Bn = rel[0::3][:, free] @ T                                   # v along x, closing
    F = np.zeros((T.shape[1], 2), complex)
    F[:, 1] = T[load]
    el = YangMenq(KE * a, KE * a, 0.3 * np.ones(a.size), 4.0 * a)
    s = System(M=red.M, C=red.C, K=red.K, Bt=np.asarray(Bt), Bn=np.asarray(Bn), contact=el,
               forcing=F)
    return s, int(np.argmax(np.abs(T[load])))


def test_refining_one_face_converges_to_the_matching_mesh():
    """The right block (its face) refined 1, 2, 3 elements across against the left
    block's fixed 4, joined through the dual mortar with the pairs stuck: the first 6
    frequencies approach the matching mesh's (4 against 4, node to node): 9.4e-4, 1.2e-4,
    2.3e-5 (measured), each refinement closer."""
    from pipeline.model.system import natural_frequencies
    w_ref = natural_frequencies(coupled_blocks(4)[0], "stuck")[:6]
    gaps = [np.abs(natural_frequencies(coupled_blocks(n)[0], "stuck")[:6] / w_ref - 1).max()
            for n in (1, 2, 3)]
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 5e-5 and gaps[0] < 2e-3
