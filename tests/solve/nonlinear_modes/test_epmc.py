"""Nonlinear modes (EPMC) against independent references: central differences of the
residual, the closed-form one-harmonic Duffing backbone, the exact period of the
undamped Duffing oscillator (complete elliptic integral), the Jenkins element's
closed-form describing function, the energy balance of every point, the cyclic
sector's mode against the assembled wheel, and the linear limits."""
import numpy as np
import pytest
from scipy.special import ellipk

from pipeline.contact import YangMenq
from pipeline.contact.cubic_spring import CubicSpring
from pipeline.contact.laws import LawElements
from pipeline.fourier.harmonics import evaluate
from pipeline.model import cyclic
from pipeline.model.system import System, natural_frequencies
from pipeline.solve.nonlinear_modes import epmc
from pipeline.solve.nonlinear_modes.backbone import continue_mode, point_at
from pipeline.model.build import sector
from pipeline.study.files.documents import load_study
from helpers import STUDIES

NONE = YangMenq(ku=np.zeros(0), kv=np.zeros(0), mu=np.zeros(0), n0=np.zeros(0))


def duffing(k3=0.5, c=0.05):
    """m x'' + c x' + k x + k3 x^3 = 0, m = k = 1."""
    return System(M=np.eye(1), C=np.array([[c]]), K=np.eye(1), Bt=np.zeros((0, 1)),
                  Bn=np.zeros((0, 1)), contact=NONE, forcing=np.zeros((1, 2), complex),
                  laws=(LawElements(CubicSpring(k3=[k3]), (np.ones((1, 1)),)),))


def jenkins(c=0.0, ku=3.0, fc=0.5):
    """m x'' + c x' + k x + f_Jenkins(x) = 0, m = k = 1, slip force fc [N]."""
    return System(M=np.eye(1), C=np.array([[c]]), K=np.eye(1), Bt=np.eye(1),
                  Bn=np.zeros((1, 1)), contact=YangMenq(ku=ku, kv=0.0, mu=0.5, n0=fc / 0.5),
                  forcing=np.zeros((1, 2), complex))


def two_dof_separating():
    """Two DOFs, one element with a normal spring that separates and a second one
    stuck to ground: every state of the Yang-Menq element along the backbone."""
    M = np.diag([1.0, 0.5])
    K = np.array([[2.0, -1.0], [-1.0, 1.5]])
    el = YangMenq(ku=[2.0, 1.0], kv=[1.5, 0.0], mu=[0.3, 0.4], n0=[0.4, 0.5])
    return System(M=M, C=0.01 * K, K=K, Bt=np.array([[1.0, -0.3], [0.0, 1.0]]),
                  Bn=np.array([[0.5, 1.0], [0.0, 0.0]]), contact=el,
                  forcing=np.zeros((2, 2), complex))


def fd_jacobian(mp, y, s, e=1e-7):
    J = np.zeros((y.size, y.size))
    for j in range(y.size):
        d = np.zeros(y.size)
        d[j] = e * max(1.0, abs(y[j]))
        J[:, j] = (epmc.residual(mp, y + d, s, False)[0]
                   - epmc.residual(mp, y - d, s, False)[0]) / (2 * d[j])
    ds = (epmc.residual(mp, y, s + e, False)[0] - epmc.residual(mp, y, s - e, False)[0]) / (2 * e)
    return J, ds


@pytest.mark.parametrize("method", ["exact", "aft"])
def test_jacobian_equals_central_differences(method):
    """dR/dy (every unknown: Q_0, Psi, omega, zeta) and dR/ds against central
    differences, at a point where the first element slips and separates."""
    mp = epmc.mode_problem(two_dof_separating(), 3, method=method, n_samples=512)
    rng = np.random.default_rng(3)
    y = epmc.linear_guess(mp) + 0.05 * rng.standard_normal(mp.size)
    y[-2], y[-1] = 1.1 * mp.omega0, 0.03
    s = 0.2
    _, J, ds = epmc.residual(mp, y, s)
    Jfd, dsfd = fd_jacobian(mp, y, s)
    assert np.abs(J - Jfd).max() <= 1e-6 * np.abs(J).max()
    assert np.abs(ds - dsfd).max() <= 1e-6 * np.abs(ds).max()


def test_duffing_one_harmonic_backbone_is_the_closed_form():
    """H = 1: omega^2 = k/m + 3/4 k3 a^2 (mass 1: a is the amplitude) and zeta = c/(2 omega)."""
    mp = epmc.mode_problem(duffing(), 1)
    bb = continue_mode(mp, -2.0, 0.5, tol_rel=1e-13)
    assert bb.message == "" and bb.s[-1] == 0.5
    a = bb.amplitude
    assert np.abs(bb.omega**2 / (1.0 + 0.75 * 0.5 * a**2) - 1).max() < 1e-10
    assert np.abs(bb.zeta * 2 * bb.omega / 0.05 - 1).max() < 1e-10


def test_undamped_duffing_period_is_the_elliptic_integral():
    """c = 0, H = 15: the frequency of the periodic orbit with maximum displacement A
    = x(0) (velocity zero at t = 0, the phase condition) is
    omega = pi sqrt(k + k3 A^2) / (2 K(m)), m = k3 A^2 / (2 (k + k3 A^2)), and zeta = 0."""
    k3 = 2.0
    mp = epmc.mode_problem(duffing(k3=k3, c=0.0), 15)
    bb = continue_mode(mp, -1.0, 0.3, tol_rel=1e-13)
    A = evaluate(bb.Q[:, 0, :], np.zeros(1))[:, 0]
    w = np.pi * np.sqrt(1 + k3 * A**2) / (2 * ellipk(k3 * A**2 / (2 * (1 + k3 * A**2))))
    assert np.abs(bb.omega / w - 1).max() < 1e-9
    assert np.abs(bb.zeta).max() < 1e-12
    assert bb.omega[-1] > 1.5   # the hardening is large at the end


def jenkins_describing_function(A, ku, fc):
    """Closed form of the Jenkins element at x = A cos(tau): equivalent stiffness Kc
    [N/m] and dissipated energy per cycle W = 4 fc (A - fc/ku) [J] in macroslip."""
    slips = ku * A > fc
    th = np.arccos(np.clip(1 - 2 * fc / (ku * A), -1, 1))
    Kc = np.where(slips, ku / np.pi * (th - np.sin(2 * th) / 2), ku)
    return Kc, np.where(slips, 4 * fc * (A - fc / ku), 0.0)


def test_jenkins_one_harmonic_frequency_and_damping_are_the_closed_form():
    """m = 1, k = 1, c = 0.01, kt = 0.25, slip force 0.2, H = 1: omega^2 = k + Kc(a) and
    zeta = c/(2 omega) + W(a)/(2 pi omega^2 a^2) at every point (1e-10), so omega ->
    sqrt(1.25) at small amplitude (1e-10) and -> 1 at large amplitude (1e-6), zeta ->
    c/(2 omega) at both ends; the friction energy per cycle of the slipping element
    (the contact's own slider work, `contact.period_results`) is 4 mu n (a - mu n / kt)."""
    from pipeline.contact.period_results import cycle_results

    kt, fc, c = 0.25, 0.2, 0.01
    mp = epmc.mode_problem(jenkins(c=c, ku=kt, fc=fc), 1)
    onset = fc / kt
    bb = continue_mode(mp, np.log10(0.01 * onset), np.log10(3e4 * onset), tol_rel=1e-13)
    assert bb.message == ""
    a = bb.amplitude
    Kc, W = jenkins_describing_function(a, kt, fc)
    assert np.abs(bb.omega**2 / (1 + Kc) - 1).max() < 1e-10
    zeta = c / (2 * bb.omega) + W / (2 * np.pi * bb.omega**2 * a**2)
    assert np.abs(bb.zeta / zeta - 1).max() < 1e-10
    assert bb.omega[0] == pytest.approx(np.sqrt(1.25), rel=1e-10)
    assert bb.omega[-1] == pytest.approx(1.0, rel=1e-6)
    assert bb.zeta[0] == pytest.approx(c / (2 * bb.omega[0]), rel=1e-10)
    # the friction share W/(2 pi omega^2 a^2) ~ 4 mu n/(2 pi a) falls like 1/a: 1.1e-3 of
    # c/(2 omega) at 3e4 slip onsets (measured 1.06e-3)
    assert bb.zeta[-1] == pytest.approx(c / (2 * bb.omega[-1]), rel=1.1e-3)
    slips = a > onset * 1.001
    energy = np.array([cycle_results(Q[:, :], Q[:, :] * 0, mp.hbm.system.contact)["energy"][0]
                       for Q in bb.Q[slips]])
    assert np.abs(energy / (4 * fc * (a[slips] - fc / kt)) - 1).max() < 1e-10


def dissipated(mp, Q, om):
    """(contact work per cycle, viscous work per cycle) [J] of the motion Q at omega."""
    _, _, G = epmc.forces(mp, Q, om, 0.0, jacobian=False)
    H = (Q.shape[1] - 1) // 2
    h = np.arange(1, H + 1)
    Qc, Qs, Gc, Gs = Q[:, 1::2], Q[:, 2::2], G[:, 1::2], G[:, 2::2]
    contact = np.pi * np.sum(h * (np.sum(Gc * Qs, 0) - np.sum(Gs * Qc, 0)))
    visc = np.pi * om * np.sum(h**2 * (np.sum(Qc * (mp.C @ Qc), 0) + np.sum(Qs * (mp.C @ Qs), 0)))
    return contact, visc


def test_every_point_balances_the_energy():
    """The EPMC damping supplies exactly what the contacts and C dissipate per cycle:
    2 pi zeta omega^2 sum_h h^2 |Q_h|_M^2 = W_contact + W_viscous (H = 5, two DOFs,
    stick, slip and separation); the modal amplitude is the mass norm of the harmonics."""
    mp = epmc.mode_problem(two_dof_separating(), 5)
    bb = continue_mode(mp, -2.0, 1.0, tol_rel=1e-12)
    assert bb.message == "" and bb.s.size > 10
    h = np.arange(1, 6)
    for s, om, ze, Q in zip(bb.s, bb.omega, bb.zeta, bb.Q):
        Qc, Qs = Q[:, 1::2], Q[:, 2::2]
        kin = np.sum(h**2 * (np.sum(Qc * (mp.M @ Qc), 0) + np.sum(Qs * (mp.M @ Qs), 0)))
        contact, visc = dissipated(mp, Q, om)
        assert 2 * np.pi * ze * om**2 * kin == pytest.approx(contact + visc, rel=1e-8)
        norm = np.sum(Qc * (mp.M @ Qc)) + np.sum(Qs * (mp.M @ Qs))
        assert norm == pytest.approx(10 ** (2 * s), rel=1e-10)


def test_exact_and_aft_backbones_agree():
    """The same mode with AFT forces (2^12 samples) to 1e-4 in frequency and damping."""
    sysm = two_dof_separating()
    mps = [epmc.mode_problem(sysm, 3, method=m, n_samples=4096) for m in ("exact", "aft")]
    bbs = [continue_mode(mp, -1.0, 0.5) for mp in mps]
    s = np.linspace(-1.0, 0.5, 7)
    pts = [[point_at(mp, b, x, 1e-10) for x in s] for mp, b in zip(mps, bbs)]
    w = [np.array([p[0] for p in row]) for row in pts]
    z = [np.array([p[1] for p in row]) for row in pts]
    assert np.abs(w[1] / w[0] - 1).max() < 1e-4
    assert np.abs(z[1] - z[0]).max() < 1e-4 * np.abs(z[0]).max()


@pytest.mark.parametrize("eo", [3, 12])
def test_cyclic_sector_mode_is_a_mode_of_the_assembled_wheel(eo):
    """The travelling-wave mode of nodal diameter EO on one sector, expanded to all 24
    sectors, satisfies the EPMC equations of the assembled wheel (no symmetry used)
    to 1e-10 of its forces; at small amplitude it is the stuck linear mode of that
    nodal diameter, at large amplitude it tends to the open one."""
    sec = sector(load_study(STUDIES / "disk_cyclic.toml").scene, {"eo": eo})
    sysS = cyclic.sector_system(sec, eo)
    mp = epmc.mode_problem(sysS, 3)
    bb = continue_mode(mp, -7.5, -1.0, tol_rel=1e-12)
    assert bb.message == ""
    full = cyclic.full_assembly(sec, eo, sparse=False)
    mpf = epmc.ModeProblem(epmc.setup(full, 3), 0, full.M, full.C, 1.0, 0.0,
                           np.zeros(full.n_dof))
    for i in (3, bb.s.size // 2, bb.s.size - 1):
        Qf = cyclic.expand(bb.Q[i], sec.sectors, eo)
        F, _, G = epmc.forces(mpf, Qf, bb.omega[i], bb.zeta[i], jacobian=False)
        assert np.abs(F).max() <= 1e-10 * np.abs(full.K @ Qf).max()
        assert np.abs(G).max() > 0
    stuck = natural_frequencies(sysS, "small")[0]
    open_ = natural_frequencies(sysS, "open")[0]
    assert bb.omega[0] == pytest.approx(stuck, rel=1e-4)
    assert bb.omega[-1] == pytest.approx(open_, rel=1e-3)
    assert point_at(mp, bb, -4.0)[0] == pytest.approx(np.interp(-4.0, bb.s, bb.omega), rel=1e-3)


# two contacts on one mass, pressing its normal DOF y: the larger preload pushes the mass
# back so far that the other contact would pull, and opens
KX, KY, KU2, KV2, MU2, N_A, N_B = 1.0e4, 1.0e4, 2.0e4, 1.0e5, 0.3, 30.0, 10.0


def one_contact_opened():
    """x (tangential) and y (normal) of a 1 kg mass on springs KX, KY to ground; contacts
    A and B both with u = x, v = y (v > 0 closes), n0 = 30 and 10 N."""
    el = YangMenq(ku=[KU2, KU2], kv=[KV2, KV2], mu=[MU2, MU2], n0=[N_A, N_B])
    Bt, Bn = np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 1.0], [0.0, 1.0]])
    return System(M=np.eye(2), C=np.zeros((2, 2)), K=np.diag([KX, KY]), Bt=Bt, Bn=Bn,
                  contact=el, forcing=np.zeros((2, 2), complex))


def test_the_mode_starts_from_the_unilateral_static_state():
    """By hand: both closed, (KY + 2 kv) y = -(n_A + n_B) gives y = -1.905e-4 m and
    s_B = 10 + kv y = -9.05 N: B would pull, so it is open.  A alone: y = -n_A / (KY + kv)
    = -2.7273e-4 m, s_A = n_A KY / (KY + kv) = 2.7273 N (B's n0 + kv y = -17.3 N: open).
    The linear mode is x with A stuck: omega0 = sqrt((KX + ku) / m) = 173.205 rad/s (both
    stuck: 223.607), and A slips at the modal amplitude mu s_A sqrt(m) / ku = 4.0909e-5
    kg^0.5 m (mu n0_B / ku = 1.5e-4 from the preloads).  Along the backbone the mode
    is linear below that amplitude (omega0, the static y) and softens above it."""
    mp = epmc.mode_problem(one_contact_opened(), 3)
    y_open = -N_A / (KY + KV2)
    s_a = N_A + KV2 * y_open
    assert N_B + KV2 * -(N_A + N_B) / (KY + 2 * KV2) < 0 and N_B + KV2 * y_open < 0
    assert s_a == pytest.approx(2.7272727273, rel=1e-10)
    assert mp.static.closed.tolist() == [True, False]
    np.testing.assert_allclose(mp.static.load, [s_a, 0.0], rtol=1e-12)
    assert mp.omega0 == pytest.approx(np.sqrt(KX + KU2), rel=1e-12)
    onset = epmc.onset_amplitude(mp)
    assert onset == pytest.approx(MU2 * s_a / KU2, rel=1e-12)
    bb = continue_mode(mp, np.log10(0.01 * onset), np.log10(3.0 * onset), tol_rel=1e-10)
    assert bb.message == ""
    a = bb.amplitude
    below, above = a < 0.99 * onset, a > 1.5 * onset
    assert below.sum() > 3 and above.sum() > 3
    np.testing.assert_allclose(bb.omega[below], np.sqrt(KX + KU2), rtol=1e-9)
    np.testing.assert_allclose(bb.Q[below, 1, 0], y_open, rtol=1e-9)
    assert np.all(bb.omega[above] < np.sqrt(KX + KU2) * (1 - 1e-6))


def two_to_one():
    """Two DOFs, DOF 0 pressed on a unilateral spring (kv = 1 N/m, n0 = 0.1 N) that
    opens as the first mode grows: omega_1 falls from 1.407 rad/s (closed) towards
    1.16 rad/s, through half the closed second mode's 2.494 rad/s, where the opening's
    second harmonic drives that mode (an internal 2:1 resonance)."""
    K = np.array([[1.0, -0.3], [-0.3, 6.2]])
    el = YangMenq(ku=[1.0], kv=[1.0], mu=[0.3], n0=[0.1])
    return System(M=np.eye(2), C=0.002 * K, K=K, Bt=np.zeros((1, 2)),
                  Bn=np.array([[1.0, 0.0]]), contact=el, forcing=np.zeros((2, 2), complex))


def test_an_internal_resonance_is_named_and_the_family_found_beyond_it():
    """H = 3: near omega = omega_2 / 2 the second harmonic takes over (the branch locks
    at omega_2 / 2 and grows on the second mode, which the old backbone reported as the
    family with no message).  The backbone stops there, names the 2:1 resonance at
    omega_2 / 2 (the closed K's second frequency, 0.1 %), and resumes the family beyond
    it: every kept point's first harmonic carries >= half the motion, and beyond the
    gap the frequency equals the H = 1 backbone's (where no internal resonance exists)
    as closely as before it (H = 1's truncation: 0.3-0.5 %; bound 1 %)."""
    from pipeline.solve.nonlinear_modes.backbone import harmonic_shares

    system = two_to_one()
    mp = epmc.mode_problem(system, 3)
    bb = continue_mode(mp, -2.0, 1.5, tol_rel=1e-9)
    one = continue_mode(epmc.mode_problem(system, 1), -2.0, 1.5, tol_rel=1e-9)
    assert one.message == "" and one.s[-1] == 1.5
    w2 = np.sqrt(np.linalg.eigvalsh(system.K + np.diag([1.0, 0.0]))[1])
    assert "internal 2:1 resonance" in bb.message and "the family skips it" in bb.message
    f_note = float(bb.message.split(" Hz)")[0].split("(")[-1])
    assert abs(f_note / (w2 / 2 / (2 * np.pi)) - 1) < 1e-3
    shares = np.array([harmonic_shares(mp, Q / np.r_[1.0, [10.0 ** s] * 6])
                       for s, Q in zip(bb.s, bb.Q)])
    assert shares[:, 0].min() >= 0.5
    jump = int(np.argmax(np.diff(bb.s)))
    assert bb.s[jump] < -0.45 and bb.s[jump + 1] > -0.45 and bb.s[-1] == 1.5
    beyond = bb.s > bb.s[jump]
    err = bb.omega[beyond] / np.interp(bb.s[beyond], one.s, one.omega) - 1
    assert np.abs(err).max() < 1e-2 and shares[beyond, 0].min() >= 0.9
