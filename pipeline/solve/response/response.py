"""Response curves: harmonic balance + continuation + Hill stability, as plain arrays.

`frequency_response` traces the periodic response of a `System` over an excitation
frequency range (pseudo-arclength continuation in Omega, folds passed);
`preload_response` traces it over a scale factor of the preloads n0 at a fixed
frequency.  Both return a `ResponseCurve` of plain numpy arrays, which the
dataset layer turns into xarray.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..harmonic_balance import hbm
from ..harmonic_balance import roundoff
from ..continuation.dense_output import PLOT_AXES, densify
from ..continuation.exact_peaks import insert_peaks
from ..continuation.pseudo_arclength import continue_branch
from ...fourier.harmonics import amplitude_half_peak_to_peak
from ..continuation.newton import newton, scale_rows
from .linear_guess import initial_guess
from .resonance import MAX_DENSE_DOF, step_guard
from .window import edge_points, follow_out, peak_points, windowed
from ..continuation.restarts import cover_range
from ..stability.branch_stability import branch_stability
from ..stability.methods import stability_mode

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ResponseCurve:
    """One continuation branch (P points) of a system with n DOFs and H harmonics."""

    parameter: np.ndarray      # (P,) continuation parameter (Omega [rad/s] or preload scale [-])
    omega: np.ndarray          # (P,) excitation frequency [rad/s]
    Q: np.ndarray              # (P, n, 2H+1) Fourier coefficients of every DOF [m]
    converged: np.ndarray      # (P,) bool: recomputed full residual <= tolerance
    residual: np.ndarray       # (P,) recomputed full residual norm [N]
    stable: np.ndarray         # (P,) bool (decided); all True where stability was not asked
    amplitude: np.ndarray      # (P, n) half peak-to-peak amplitude [m]
    fold_parameter: np.ndarray  # (F,) parameter values of the detected folds
    newton_iterations: np.ndarray  # (P,)
    nfev: int                  # residual evaluations in total
    wall_time: float           # [s]
    success: bool
    status: int
    message: str
    H: int
    tolerance: float           # [N]
    info: dict = field(default_factory=dict)
    # decided stability (`stability_check`): -1 not computed, 0 Hill, 1 Floquet,
    # 2 monodromy along the HBM orbit; Hill's exp(max Re lam T), Floquet's and the
    # orbit monodromy's max |mu| (NaN where not run); bifurcations where
    # the decided flag changes (kind 1 fold, 2 period doubling, 3 Neimark-Sacker)
    stability_method: np.ndarray | None = None
    hill_multiplier: np.ndarray | None = None
    floquet_multiplier: np.ndarray | None = None
    monodromy_multiplier: np.ndarray | None = None
    bifurcation_parameter: np.ndarray | None = None
    bifurcation_kind: np.ndarray | None = None
    # (F, n) amplitude of every DOF at each fold [m] (`fold_amplitudes`); NaN where the
    # fold's state does not meet the residual tolerances
    fold_amplitude: np.ndarray | None = None

    @property
    def n_points(self) -> int:
        return self.parameter.size

    def peak(self, dof: int):
        """(amplitude, omega, index) of the largest converged amplitude of a DOF inside
        info["window"] [lo, hi] [rad/s] where given (a branch followed beyond it:
        `window.follow_out`): the peak of the range only if `success` (else the
        curve stopped short of it)."""
        w = self.info.get("window", (-np.inf, np.inf))
        inside = self.converged & (self.omega >= w[0]) & (self.omega <= w[1])
        a = np.where(inside, self.amplitude[:, dof], -np.inf)
        i = int(np.argmax(a))
        return float(a[i]), float(self.omega[i]), i


GUESS_NFEV = 2  # residual evaluations of `initial_guess` (R alone, at its two guesses)


def frequency_response(system, H, omega_start, omega_end, *, method="exact", n_samples=256,
                       stability=True, tol_rel=1e-10, ds=0.02, ds_max=0.1, max_points=1000,
                       contact=None, callback=None, peak_dofs=None,
                       initial=None, dense_output=True, keep="curve") -> ResponseCurve:
    """Trace the periodic response over Omega in [omega_start, omega_end] [rad/s].

    Pseudo-arclength continuation (`continuation.continue_branch`) of the condensed
    HBM residual (`hbm.residual`), all DOFs recovered, each point's full residual
    recomputed (converged iff its static and harmonic parts are each within
    `hbm.tolerances` [N], raised where it is smaller to the residual's round-off floor
    at that point: `roundoff`, counted in info["roundoff_points"]), stability of the full system decided by `stability`
    (True = "hill", "floquet", "hill+check", "monodromy", "monodromy+check" or False:
    `stability_check`).

    First point: Newton from `initial` (Fourier coefficients (n, 2H+1) of all DOFs,
    e.g. a known solution) if given, else from the better linear guess (contacts
    open or stuck); then continuation in the excitation level, then in the contact
    stiffness (`_cold_start`, `_stiffness_start`).  A branch that turns back past
    omega_start (a start between two folds) is followed through its next fold and
    its other side traced too (`restarts.trace_range`); one that does not reach
    omega_end at all is traced from omega_end instead.  A curve that does not cover the
    range has success False and says why in its message.

    No step jumps over a resonance: `resonance.step_guard` shortens every step
    across which the count of the linearised structure's natural frequencies
    below h Omega changes, until it resolves the resonance; a step it could not
    shorten enough is counted in info["unresolved_resonance_steps"].  With
    `dense_output`, points are added where the drawn curves (frequency, amplitude
    of the `peak_dofs` on a linear and a log axis; "linear" or "log": that axis
    only) bend (`densify`), so that figures are smooth at their resolution.  The
    peaks of the `peak_dofs` are then located exactly (`insert_peaks`).

    keep="peaks" (a Monte-Carlo sample reads each DOF's largest peak only): no dense
    output, only the local maxima that can be a DOF's largest are located
    (`insert_peaks(largest=True)`), and the curve keeps only the points where a DOF
    of `peak_dofs` has its largest amplitude (full residual and stability checked
    there); its info["branch_points"] still counts the branch traced.
    """
    if keep not in KEEP:
        raise ValueError(f"keep must be one of {KEEP}, got {keep!r}")
    if keep == "peaks":
        dense_output = False
    t_start = time.perf_counter()
    stability_mode(stability)  # misuse raises before the continuation
    axes = dense_axes(dense_output) if dense_output else None
    ds = min(ds, ds_max)  # a small max_step also bounds the first step
    fp = frequency_problem(system, H, method, n_samples, tol_rel, contact)
    prob, elem, tols, fun, tol, groups, guard = (fp.prob, fp.elem, fp.tols, fp.fun, 1.0,
                                                 fp.groups, fp.guard)
    kw = dict(ds=ds, ds_max=ds_max, max_points=max_points, callback=callback,
              segment_check=guard)
    initial = fp.checked_state(initial)
    br, spent = cover_range(fun, fp.start_at, omega_start, omega_end, tol, groups, initial,
                            **kw)
    dofs = list(peak_dofs if peak_dofs is not None else range(system.n_dof))
    window = (min(omega_start, omega_end), max(omega_start, omega_end))
    br, notes, A = follow_out(fp, br, window, dofs, **kw) if br.success else (br, [], None)
    pts = branch_points(br)
    if A is not None:   # read by `insert_peaks` (not drawn again)
        pts["amplitude"], pts["amplitude_dofs"] = A, dofs
    pts = edge_points(fp, pts, window)
    if time.perf_counter() - t_start > LONG_BRANCH:   # a long case says what comes next
        log.info("branch: %d points in %.0f s; now its %s", len(br.lam),
                 time.perf_counter() - t_start,
                 "dense output and peaks" if axes else "peaks")
    if axes:
        pts = densify(prob, pts, fun, tol, dofs, axes=axes)
    pts = insert_peaks(prob, pts, fun, tol, elem, dofs, largest=keep == "peaks", window=window)
    if keep == "peaks":
        pts = peak_points(prob, pts, dofs, window)
    pts["resonance_guard"] = guard is not None
    return windowed(curve_from_points(prob, br, pts, lambda lam: elem, tols, stability,
                                      lambda lam: lam, time.perf_counter() - t_start, spent),
                    window, dofs, notes)


LONG_BRANCH = 30.0   # [s] a branch traced longer than this is logged before its peaks
KEEP = ("curve", "peaks")  # what `frequency_response` keeps of the branch


@dataclass(frozen=True)
class FrequencyProblem:
    """The condensed harmonic balance of a system over Omega, as continuation sees it:
    `fun(x, Omega) -> (R, J, dR/dOmega)` with every equation divided by its tolerance
    (`weighted`; converged at |R| <= 1), `tols` (static, harmonic) [N], the DOF
    groups of the automatic scale, the resonance guard (None where not applicable)."""

    prob: object
    elem: object
    tols: tuple
    floored: object
    fun: object
    groups: np.ndarray
    guard: object

    def start_at(self, Om, guess=None):
        """The first point at Om [rad/s] (`first_point`): from `guess` (all DOFs'
        coefficients) if given, else the linear guesses and the homotopies."""
        return first_point(self.prob, self.elem, Om, self.floored,
                           lambda x: self.fun(x, Om)[:2], guess)

    def checked_state(self, Q):
        """Q as finite Fourier coefficients (n, 2H+1) of all DOFs (None passes)."""
        if Q is None:
            return None
        Q = np.asarray(Q, dtype=float)
        shape = (self.prob.system.n_dof, self.prob.nh)
        if Q.shape != shape or not np.all(np.isfinite(Q)):
            raise ValueError(f"initial must be finite Fourier coefficients of shape "
                             f"{shape}, got {Q.shape}")
        return Q


def frequency_problem(system, H, method="exact", n_samples=256, tol_rel=1e-10,
                      contact=None) -> FrequencyProblem:
    """`FrequencyProblem` of `system` at H harmonics (`contact`: other elements than
    the system's), its tolerances from `tol_rel` (`hbm.tolerances`), raised to the
    round-off floor where that is larger (`roundoff.FlooredWeights`)."""
    prob = hbm.setup(system, H, method, n_samples)
    elem = contact if contact is not None else system.contact
    tols = hbm.tolerances(prob, tol_rel, elem)
    floored = roundoff.FlooredWeights(prob, tols, roundoff.load_scales(prob, elem))
    fun = weighted(lambda x, lam: hbm.residual(prob, x, lam, elem), floored)
    return FrequencyProblem(prob, elem, tols, floored, fun,
                            np.repeat(np.arange(prob.c.size), prob.nh),
                            step_guard(prob, lambda lam: elem))


def dense_axes(dense_output) -> tuple:
    """The amplitude axes `densify` draws for `dense_output` (True: both); a
    ValueError for anything but a bool, "linear" or "log"."""
    if dense_output is True:
        return PLOT_AXES
    if dense_output in PLOT_AXES:
        return (dense_output,)
    raise ValueError(f"dense_output must be True, False, 'linear' or 'log', got "
                     f"{dense_output!r}")


def first_point(prob, elem, Om, w, fun_x, guess=None):
    """The first point at fixed parameter: Newton (weighted residual `fun_x`, tol 1)
    from `guess` (all DOFs' coefficients) if given, else from the better linear
    guess; then the load and the stiffness homotopies, their equations weighted by
    `w(x, R, J)` (`roundoff.FlooredWeights`: a tolerance below round-off does not stop
    them).  (NewtonResult, nfev spent)."""
    spent = 0
    if guess is not None:
        nr = newton(fun_x, guess[prob.c].ravel(), 1.0, max_iter=60)
        spent += nr.nfev
        if nr.success:
            return nr, spent
    nr = newton(fun_x, initial_guess(prob, Om, elem), 1.0, max_iter=60)
    spent += GUESS_NFEV + nr.nfev
    for start in (_cold_start, _stiffness_start):
        if nr.success:
            break
        nr, n = start(prob, elem, Om, w, nr)
        spent += n
    return nr, spent


def _cold_start(prob, elem, Om, w, failed):
    """First point by continuation in the load: R_s = R + (1 - s) P~ from s = 0 (no
    excitation: the static state under the preloads) to s = 1, at fixed Om.  Used
    when Newton from the linear guesses fails (strong impact, a gap that closes).
    Returns (NewtonResult, nfev spent); `failed` if the homotopy fails."""
    _, _, Pt, _ = hbm.linear_part(prob, Om, derivatives=False, pattern=prob.pattern)
    P = hbm.real_vector(Pt, prob.nh).ravel()

    def fun_s(x, s):
        R, J, _ = hbm.residual(prob, x, Om, elem)
        Rs = R + (1.0 - s) * P
        ws = w(x, Rs, J)
        return ws * Rs, scale_rows(ws, J), -ws * P

    st = newton(lambda x: fun_s(x, 0.0)[:2], np.zeros(prob.size), 1.0, max_iter=60)
    if not st.success:
        return failed, st.nfev
    br = continue_branch(fun_s, st.x, 0.0, 1.0, tol=1.0,
                         groups=np.repeat(np.arange(prob.c.size), prob.nh))
    spent = st.nfev + br.nfev
    if not (br.success and br.lam.size and br.lam[-1] == 1.0):
        return failed, spent
    nr = newton(lambda x: fun_s(x, 1.0)[:2], br.x[-1], 1.0, max_iter=10)
    return nr, spent + nr.nfev


def _stiffness_start(prob, elem, Om, w, failed, decades=(1, 2, 3, 4)):
    """First point by continuation in the contact stiffness: ku and kv scaled by
    10**p from a soft contact p0 = -d (d in `decades`, until Newton from the linear
    guesses converges and the branch reaches p = 0), at fixed Om, on log scale (stiff impact
    spans decades).  Used when stiff impact defeats both Newton from the linear
    guesses and the load homotopy (whose branch then meets a cascade of folds).
    Returns (NewtonResult, nfev spent); `failed` if no decade leads to p = 0."""
    def el(p):
        f = 10.0 ** p
        return replace(elem, ku=elem.ku * f, kv=elem.kv * f)

    def fun_p(x, p):
        R, J, _ = hbm.residual(prob, x, Om, el(p))
        Qc = x.reshape(prob.c.size, prob.nh)
        d = 1e-6
        Gp = hbm.contact_terms(prob, Qc, el(p + d), False)[0]
        Gm = hbm.contact_terms(prob, Qc, el(p - d), False)[0]
        wp = w(x, R, J)
        return wp * R, scale_rows(wp, J), wp * ((Gp - Gm) / (2 * d)).ravel()

    groups = np.repeat(np.arange(prob.c.size), prob.nh)
    spent = 0
    for dec in decades:
        p0 = -float(dec)
        st = newton(lambda x: fun_p(x, p0)[:2], initial_guess(prob, Om, el(p0)), 1.0,
                    max_iter=30)
        spent += GUESS_NFEV + st.nfev
        if not st.success:
            continue
        br = continue_branch(fun_p, st.x, p0, 0.0, tol=1.0, max_points=2000, groups=groups)
        spent += br.nfev
        if br.success and br.lam.size and br.lam[-1] == 0.0:
            nr = newton(lambda x: fun_p(x, 0.0)[:2], br.x[-1], 1.0, max_iter=10)
            return nr, spent + nr.nfev
    return failed, spent


def weighted(fun, weights):
    """fun(x, lam) -> (R, J, dR) with every equation divided by its tolerance [N]
    (row scaling: Newton steps and tangents are unchanged, only the test is), raised
    to the residual's round-off floor at (x, lam) where that is larger
    (`roundoff.FlooredWeights`).  A dense J is scaled in place: `hbm.residual`
    returns a fresh one per call."""
    def f(x, lam):
        R, J, dR = fun(x, lam)
        w = weights(x, R, J)
        return (w * R, (None if J is None else scale_rows(w, J, in_place=True)),
                (None if dR is None else w * dR))
    return f


def branch_points(br):
    return {"x": np.array(br.x), "lam": np.array(br.lam), "nit": np.array(br.nit),
            "converged": np.array(br.converged, bool), "extra_nfev": 0,
            "tangent": list(np.array(br.tangent)), "scale": np.array(br.scale)}


def curve_from_points(prob, br, pts, elem_at, tols, stability, omega_of, elapsed, extra_nfev):
    """ResponseCurve from branch points: all DOFs recovered, the full residual of each
    point recomputed and split into static and harmonic parts, each held to its
    tolerance [N]; Hill stability of the full system.  elem_at(lam) gives the
    contact elements at a parameter value (they change with it in preload mode)."""
    t0 = time.perf_counter()
    P = pts["lam"].size
    n, nh = prob.system.n_dof, prob.nh
    Q = np.zeros((P, n, nh))
    res = np.zeros(P)
    ok, floor = np.zeros(P, bool), np.zeros(P, bool)
    omega = np.array([omega_of(l) for l in pts["lam"]], dtype=float)
    for i in range(P):
        el = elem_at(pts["lam"][i])
        Q[i] = hbm.recover(prob, pts["x"][i].reshape(prob.c.size, nh), omega[i])
        res[i], ok[i], floor[i] = roundoff.check_point(prob, Q[i], omega[i], el, tols)
    converged = pts["converged"] & ok & np.isfinite(res)
    n_floor = int(np.sum(floor & converged))
    if n_floor:
        log.warning(
            "%d of %d points accepted on the round-off floor of their residual, above the "
            "tolerance (static %.3g N, harmonic %.3g N): the tolerance lies below what "
            "double precision resolves for this model near its peaks", n_floor, P, *tols)
    amp = amplitude_half_peak_to_peak(Q) if P else np.zeros((0, n))
    bs = branch_stability(prob, Q, omega, pts["lam"], elem_at, converged, stability,
                          br.fold_lam, amp)
    fold_amp = fold_amplitudes(prob, br, elem_at, tols, omega_of)
    return ResponseCurve(
        parameter=np.asarray(pts["lam"], float), omega=omega, Q=Q, converged=converged,
        residual=res, stable=bs.stable, amplitude=amp,
        fold_parameter=np.asarray(br.fold_lam, float),
        newton_iterations=np.asarray(pts["nit"]),
        nfev=int(br.nfev + extra_nfev + pts["extra_nfev"] + pts.get("dense_nfev", 0)),
        wall_time=elapsed + time.perf_counter() - t0, success=bool(br.success),
        status=int(br.status), message=str(br.message) + _guard_note(br, pts), H=prob.H,
        tolerance=float(np.hypot(*tols)),  # implied by both blocks within theirs
        info={"njev": int(br.njev), "n_rejected": int(br.n_rejected),
              "unresolved_resonance_steps": int(br.n_unresolved),
              "resonance_guard": bool(pts.get("resonance_guard", False)),
              "min_step": float(br.min_step), "branch_points": int(br.lam.size),
              "tol_static": float(tols[0]), "tol_dynamic": float(tols[1]),
              "roundoff_points": n_floor,
              "peak_nfev": int(pts["extra_nfev"]), "solve_time": elapsed,
              "dense_points": int(pts.get("dense_points", 0)),
              "dense_nfev": int(pts.get("dense_nfev", 0)),
              "postprocess_time": time.perf_counter() - t0, "stability": bs.note,
              "hill_time": bs.hill_time, "floquet_time": bs.floquet_time,
              "monodromy_time": bs.monodromy_time},
        stability_method=bs.method, hill_multiplier=bs.hill_multiplier,
        floquet_multiplier=bs.floquet_multiplier, monodromy_multiplier=bs.monodromy_multiplier,
        bifurcation_parameter=bs.bifurcation_parameter, bifurcation_kind=bs.bifurcation_kind,
        fold_amplitude=fold_amp)


def fold_amplitudes(prob, br, elem_at, tols, omega_of=lambda lam: lam):
    """(F, n) amplitude (half peak-to-peak) of every DOF at each fold of the Branch
    `br` [m]: the fold's state (`branch.refine_fold`) recovered on all DOFs and its
    full residual held to the tolerances `tols` [N] like every point's; NaN where it
    is not met (a fold whose corrector failed stays at its interpolated place)."""
    lams = np.asarray(br.fold_lam, float)
    out = np.full((lams.size, prob.system.n_dof), np.nan)
    for k, lam in enumerate(lams):
        om = omega_of(lam)
        Q = hbm.recover(prob, np.asarray(br.fold_x[k]).reshape(prob.c.size, prob.nh), om)
        if roundoff.check_point(prob, Q, om, elem_at(lam), tols)[1]:
            out[k] = amplitude_half_peak_to_peak(Q)
    return out


def _guard_note(br, pts) -> str:
    """What the curve's message says when a peak between two points is not excluded."""
    if not pts.get("resonance_guard", False):
        return ("; resonances between points not checked (no excited harmonic, or more "
                f"than {MAX_DENSE_DOF} DOFs not split into independent parts)")
    if br.n_unresolved:
        return (f"; {br.n_unresolved} step(s) across a resonance could not be shortened to "
                "its half-power band: a peak may hide there")
    return ""


def _with_preload(elem, lam, shape):
    return replace(elem, n0=lam * shape)


def preload_response(system, H, omega, preload_start, preload_end, *, method="exact",
                     n_samples=256, stability=True, tol_rel=1e-10, ds=0.02, ds_max=0.1,
                     max_points=1000, peak_dofs=None) -> ResponseCurve:
    """Trace the response at fixed Omega [rad/s] over the preload [N].

    Every element's preload is n0_e = lam * shape_e with shape = n0 / max|n0| of the
    system (all ones if every n0 is 0), so lam is the largest preload.  dR/dlam is
    a central difference of the contact forces (the linear part does not depend on
    n0); dR/dQ stays exact.
    """
    t_start = time.perf_counter()
    ds = min(ds, ds_max)
    prob = hbm.setup(system, H, method, n_samples)
    base = system.contact
    top = np.abs(base.n0).max()
    shape = base.n0 / top if top > 0 else np.ones_like(base.n0)

    def fun(x, lam, jacobian=True):
        el = _with_preload(base, lam, shape)
        R, J, _ = hbm.residual(prob, x, omega, el, jacobian)
        if not jacobian:
            return R, None, None
        d = 1e-6 * max(abs(lam), 1e-3 * max(abs(preload_start), abs(preload_end), 1e-9))
        Qc = x.reshape(prob.c.size, prob.nh)
        Gp = hbm.contact_terms(prob, Qc, _with_preload(base, lam + d, shape), False)[0]
        Gm = hbm.contact_terms(prob, Qc, _with_preload(base, lam - d, shape), False)[0]
        return R, J, ((Gp - Gm) / (2 * d)).ravel()

    tols = tuple(max(a, b) for a, b in zip(
        hbm.tolerances(prob, tol_rel, _with_preload(base, preload_start, shape)),
        hbm.tolerances(prob, tol_rel, _with_preload(base, preload_end, shape))))
    raw = fun
    loads = np.max([roundoff.load_scales(prob, _with_preload(base, p, shape))
                    for p in (preload_start, preload_end)], axis=0)
    floored = roundoff.FlooredWeights(prob, tols, loads)
    fun = weighted(lambda x, lam: raw(x, lam), floored)

    def start_at(lam, guess=None):
        return first_point(prob, _with_preload(base, lam, shape), omega, floored,
                            lambda x: fun(x, lam)[:2], guess)

    guard = step_guard(prob, lambda lam: _with_preload(base, lam, shape), lambda lam: omega)
    br, spent = cover_range(fun, start_at, preload_start, preload_end, 1.0,
                             np.repeat(np.arange(prob.c.size), prob.nh), ds=ds, ds_max=ds_max,
                             max_points=max_points, segment_check=guard)
    pts = branch_points(br)
    pts["resonance_guard"] = guard is not None
    return curve_from_points(prob, br, pts, lambda lam: _with_preload(base, lam, shape), tols,
                              stability, lambda lam: omega, time.perf_counter() - t_start, spent)
