"""The results the shipped studies state in their comments, recomputed from the studies
themselves (a comment that drifts from its study fails here).

Each claim is (study file, the text stated, the value recomputed, the tolerance of the
text's last digit).  `test_every_stated_frequency_is_checked` keeps the list complete:
every number given in Hz or rad/s in a study's comments is either one of its claims
or an input of the same file.
"""
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from pipeline.model.cyclic import sector_system
from pipeline.model.build import build_system, sector
from pipeline.model.system import natural_frequencies
from pipeline.study.files.documents import load_study

from helpers import stated

STUDIES = Path(__file__).resolve().parents[3] / "studies"
TWO_PI = 2 * np.pi


def hz(w):
    return np.asarray(w) / TWO_PI


def text(name):
    return (STUDIES / name).read_text()


# --------------------------------------------------------------------------- paper examples
def test_paper_example1_linear_limits():
    s = build_system(load_study(STUDIES / "paper_example1.toml").scene, {"preload": 0.0})
    open_w, stuck_w = stated("paper_example1.toml",
                             r"sqrt\(k/m\) = ([\d.]+), sqrt\(\(k\+ku\)/m\) = ([\d.]+)")
    k, m, ku = s.K[0, 0], s.M[0, 0], s.contact.ku[0]
    assert np.sqrt(k / m) == pytest.approx(open_w, abs=0.05)
    assert np.sqrt((k + ku) / m) == pytest.approx(stuck_w, abs=0.05)


def test_paper_example2_natural_frequencies():
    s = build_system(load_study(STUDIES / "paper_example2.toml").scene, {"preload": 100.0})
    f = stated("paper_example2.toml", r"without the damper ([\d.]+) and\n# ([\d.]+) Hz, "
                                      r"with it stuck ([\d.]+) and ([\d.]+) Hz")
    np.testing.assert_allclose(hz(natural_frequencies(s, "open")), f[:2], atol=0.005)
    np.testing.assert_allclose(hz(natural_frequencies(s, "stuck")), f[2:], atol=0.005)
    lo, hi = stated("paper_example2.toml", r"# ([\d.]+) - ([\d.]+) rad/s, both modes")
    st = load_study(STUDIES / "paper_example2.toml")
    assert st.sweep.frequency.omega_start == pytest.approx(lo, abs=0.05)
    assert st.sweep.frequency.omega_stop == pytest.approx(hi, abs=0.5)


def test_paper_example3_harmonic_convergence_of_the_peak():
    """'the peak moves 1.3 % from H = 7 to 14, 5e-5 from 14 to 21' (n0 = 10 N)."""
    from pipeline.solve.response.response import frequency_response
    step_7, step_14 = stated("paper_example3.toml",
                             r"the peak moves ([\d.]+) % from H = 7 to 14, ([\d.e-]+) from 14 to 21")
    s = build_system(load_study(STUDIES / "paper_example3.toml").scene, {"preload": 10.0})
    peak = {H: frequency_response(s, H, 0.8, 1.6, stability=False, dense_output=False,
                                  tol_rel=1e-10).peak(0)[0] for H in (7, 14, 21)}
    assert abs(peak[14] / peak[7] - 1) * 100 == pytest.approx(step_7, abs=0.05)
    assert abs(peak[21] / peak[14] - 1) == pytest.approx(step_14, rel=0.1)


# --------------------------------------------------------------------------- lumped disks
def test_disk_cyclic_uncoupled_blade_frequency():
    """'EO = 0: ... the linear uncoupled blade (377.6 Hz)'; 'sqrt(k/m) = 2 pi 300 Hz'."""
    (f_km,) = stated("disk_cyclic.toml", r"sqrt\(k/m\) = 2 pi ([\d.]+) Hz")
    assert hz(np.sqrt(3.55e5 / 0.1)) == pytest.approx(f_km, abs=0.5)
    (f,) = stated("disk_cyclic.toml", r"uncoupled\n#\s+blade \(([\d.]+) Hz\)")
    st = load_study(STUDIES / "disk_cyclic.toml")
    s = build_system(st.scene, st.sweep.cases()[0][1])
    w2 = sla.eigh(s.K, s.M, eigvals_only=True)
    assert hz(np.sqrt(w2[0])) == pytest.approx(f, abs=0.05)


# --------------------------------------------------------------------------- FE blade
def test_blade_shroud_contact_damping_ratio():
    """Rayleigh C = alpha M + beta K: zeta(w) = alpha/(2w) + beta w/2, least at
    w = sqrt(alpha/beta) with zeta = sqrt(alpha beta)."""
    zmin, fmin, zat, fat = stated("blade_shroud_contact.toml",
                                  r"([\d.]+) % at its minimum \(([\d.]+) Hz\), ([\d.]+) % at ([\d.]+) Hz")
    a, b = load_study(STUDIES / "blade_shroud_contact.toml").scene.structure.rayleigh
    assert 100 * np.sqrt(a * b) == pytest.approx(zmin, abs=0.005)
    assert hz(np.sqrt(a / b)) == pytest.approx(fmin, abs=0.5)
    w = TWO_PI * fat
    assert 100 * (a / (2 * w) + b * w / 2) == pytest.approx(zat, abs=0.005)


# --------------------------------------------------------------------------- FE disk
@pytest.fixture(scope="module")
def shrouded_disk_nd3():
    """The sector of studies/shrouded_disk.toml at ND 3 (its engine order), full mesh."""
    st = load_study(STUDIES / "shrouded_disk.toml")
    return sector_system(sector(st.scene, {"preload": 1.0}), st.scene.assembly.engine_order)


def test_shrouded_disk_limits_of_the_first_family(shrouded_disk_nd3):
    """Open blade, shrouds sliding in permanent contact (kv alone) and stuck, at ND 3."""
    from dataclasses import replace
    f_open, f_slide, f_stuck = stated(
        "shrouded_disk.toml", r"open blade \(([\d.]+) Hz\).*\n.*\(kv alone, ([\d.]+) Hz\)"
                              r"(?:.*\n)+?.*\(([\d.]+) Hz\) with no friction damping")
    s = shrouded_disk_nd3
    sliding = replace(s, contact=replace(s.contact, ku=np.zeros_like(s.contact.ku)))
    assert hz(natural_frequencies(s, "open")[0]) == pytest.approx(f_open, abs=0.05)
    assert hz(natural_frequencies(sliding, "tied")[0]) == pytest.approx(f_slide, abs=0.05)
    assert hz(natural_frequencies(s, "tied")[0]) == pytest.approx(f_stuck, abs=0.05)


def test_shrouded_disk_modes_matches_the_response_study_and_its_comment(shrouded_disk_nd3):
    """The modes study describes the same contacts as the response study, and the
    first family it states: open at every ND, stuck at ND 0, 3 (EO 3) and 18."""
    from pipeline.study.execution.disk_modes_study import nodal_diameter_frequencies
    modes = load_study(STUDIES / "shrouded_disk_modes.toml")
    resp = load_study(STUDIES / "shrouded_disk.toml")
    assert modes.scene.contacts == resp.scene.contacts
    assert modes.scene.structure == resp.scene.structure
    f_open, f0, f3, f18 = stated("shrouded_disk_modes.toml",
                                 r"blade's ([\d.]+) Hz at every ND; stuck, it rises from ([\d.]+) Hz "
                                 r"\(ND 0\) through\n# ([\d.]+) Hz \(ND 3.*\) to ([\d.]+) Hz \(ND 18\)")
    res = nodal_diameter_frequencies(modes.scene, (0, 3, 18), 1)
    np.testing.assert_allclose(res["open"][:, 0], f_open, atol=0.05)
    np.testing.assert_allclose(res["stuck"][:, 0], [f0, f3, f18], atol=0.05)
    assert hz(natural_frequencies(shrouded_disk_nd3, "tied")[0]) == pytest.approx(f3, abs=0.05)


def test_bladed_disk_sector_against_the_rigid_disk():
    """'the first flap family's stuck frequency at ND 3 is 320.5 Hz against 322.4 Hz on a
    rigid disk; the second family ... at ND 0 (1248 against 1463 Hz) and by 0.2 % at
    ND 18', recomputed: the flexible sector of the shipped deck (the response study's
    scene) and the rigid-disk wheel of studies/shrouded_disk_modes.toml."""
    from pipeline.study.execution.disk_modes_study import nodal_diameter_frequencies
    f3, f3_rigid, f0, f0_rigid = stated(
        "bladed_disk_sector.toml", r"ND 3 is ([\d.]+) Hz against ([\d.]+) Hz on a rigid disk"
                                   r"(?:.*\n)+?.*at ND 0 \(([\d.]+) against ([\d.]+) Hz\)")
    drop18 = stated("bladed_disk_sector.toml", r"by ([\d.]+) % at\n# ND 18")[0]
    flexible = load_study(STUDIES / "bladed_disk_sector.toml").scene
    rigid = load_study(STUDIES / "shrouded_disk_modes.toml").scene
    a, b = (nodal_diameter_frequencies(sc, (0, 3, 18), 2)["stuck"] for sc in (flexible, rigid))
    assert a[1, 0] == pytest.approx(f3, abs=0.05) and b[1, 0] == pytest.approx(f3_rigid, abs=0.05)
    assert a[0, 1] == pytest.approx(f0, abs=0.5) and b[0, 1] == pytest.approx(f0_rigid, abs=0.5)
    assert 100 * (1 - a[2, 1] / b[2, 1]) == pytest.approx(drop18, abs=0.05)
    assert 100 * (1 - a[0, 1] / b[0, 1]) == pytest.approx(15, abs=0.5)
    f_open = stated("bladed_disk_sector.toml", r"open blade\n#\s+\(([\d.]+) Hz\)")[0]
    assert nodal_diameter_frequencies(flexible, (3,), 1)["open"][0, 0] == pytest.approx(
        f_open, abs=0.05)


# --------------------------------------------------------------------------- completeness
def test_shrouded_disk_campbell_comment():
    """'stuck ND 3 from 322.4 Hz at rest to 467.6 Hz at 15,000 rpm; EO 3 crosses it
    (stuck) at 7,243 rpm'; 'EO 6 at 2,187 rpm' (open); EO 1 crosses nothing."""
    from pipeline.study.execution.campbell_study import campbell

    st = load_study(STUDIES / "shrouded_disk_campbell.toml")
    f0, f1 = stated("shrouded_disk_campbell.toml", r"from ([\d.]+) Hz at rest to\n#\s+([\d.]+) Hz")
    s3, s6 = (float(v.replace(",", "")) for v in re.search(
        r"\(stuck\) at ([\d,]+) rpm;.*?EO 6 at ([\d,]+) rpm", text(
            "shrouded_disk_campbell.toml"), re.S).groups())
    res = campbell(st.scene, st.speeds, (1, 3, 6), 1, (1, 3, 6))
    assert res["stuck"][0, 1, 0] == pytest.approx(f0, abs=0.05)
    assert res["stuck"][-1, 1, 0] == pytest.approx(f1, abs=0.05)
    at = {(eo, state): s for eo, _, k, state, s, _ in res["crossings"] if k == 1}
    assert at[(3, "stuck")] == pytest.approx(s3, abs=0.5)
    assert at[(6, "open")] == pytest.approx(s6, abs=0.5)
    assert not any(eo == 1 for eo, *_ in res["crossings"])


def test_shrouded_disk_speed_closing_speed():
    """'The first pair closes at 6,863 rpm (0.1 mm over v_c per Omega^2)'."""
    from pipeline.model.contacts import fe_contact_maps
    from pipeline.model.blade_cache import RPM, blade_model

    st = load_study(STUDIES / "shrouded_disk_speed.toml")
    stated_rpm = float(re.search(r"first pair closes at ([\d,]+) rpm",
                                 text("shrouded_disk_speed.toml")).group(1).replace(",", ""))
    blade = blade_model(st.scene.structure)
    _, Bn, _, Bn_next, _, _ = fe_contact_maps(blade, st.scene.contacts, st.scene.structure.disk)
    v1 = (Bn + Bn_next) @ blade.rotation.static
    gap = -st.scene.contacts[0].interference
    assert np.sqrt(gap / v1.max()) / RPM == pytest.approx(stated_rpm, abs=0.5)


def test_shrouded_disk_2d_stuck_family_and_face_frame(shrouded_disk_nd3):
    """'the stuck ND 3 frequency rises to 345.4 Hz (322.4 Hz with the 1D pairs)', and
    the face frame the comment gives (normal, t1, t2 to 1e-3)."""
    from pipeline.model.contacts import pair_frame
    from pipeline.model.blade_cache import blade_model
    f2, f1 = stated("shrouded_disk_2d.toml", r"rises to ([\d.]+) Hz \(([\d.]+) Hz with")
    st = load_study(STUDIES / "shrouded_disk_2d.toml")
    plane = sector_system(sector(st.scene, {"preload": 1.0}), st.scene.assembly.engine_order)
    assert hz(natural_frequencies(plane, "tied")[0]) == pytest.approx(f2, abs=0.05)
    assert hz(natural_frequencies(shrouded_disk_nd3, "tied")[0]) == pytest.approx(f1, abs=0.05)
    n_, t1, t2 = (np.array(stated("shrouded_disk_2d.toml", rf"{w} \(([-\d.]+), ([-\d.]+), "
                                  r"([-\d.]+)\)")) for w in ("normal", "only, t1 =", "n x t1 ="))
    t, n = pair_frame(blade_model(st.scene.structure), st.scene.contacts[0],
                      st.scene.structure.disk)
    for got, want in ((n, n_), (t, t1), (np.cross(n, t), t2)):
        np.testing.assert_allclose(got, want, atol=1e-3)


CHECKED = {   # study -> the stated results above (numbers followed by Hz or rad/s)
    "paper_example1.toml": {188.4, 213.3},
    "paper_example2.toml": {19.67, 51.50, 23.53, 56.97, 81.7, 421.0},
    "disk_cyclic.toml": {377.6, 300.0},
    "accuracy_cost.toml": {494.4},
    "blade_shroud_contact.toml": {356.0, 497.6, 403.6},
    "shrouded_disk.toml": {212.9, 300.9, 322.4},
    "shrouded_disk_2d.toml": {345.4, 322.4},
    "shrouded_disk_modes.toml": {212.9, 213.9, 322.4, 877.1},
    "bladed_disk_sector.toml": {210.6, 320.5, 322.4, 1463.0},
    "shrouded_disk_campbell.toml": {322.4, 467.6},
    "shrouded_disk_mistuned.toml": {271.3},
    "shrouded_disk_monte_carlo.toml": {271.3},   # the same wheel and window
    "blade3_stability.toml": {112.0, 121.0, 115.9, 117.5},   # test_stability_check.py
    # 377.6, 383.4, 458.3, 508.6: test_shipped_studies.py; 498.0 (ND 6) below
    "disk_nonlinear_modes.toml": {377.6, 383.4, 458.3, 498.0, 508.6},
    "shrouded_disk_nonlinear_modes.toml": {324.5, 271.9, 216.3, 215.6, 321.5},
}


def comment_frequencies(name):
    """Numbers followed by Hz or rad/s in the comments of a study (ranges a-b count
    both ends)."""
    out = set()
    for line in text(name).splitlines():
        if "#" not in line:
            continue
        c = line.split("#", 1)[1]
        for m in re.finditer(r"([\d.]+(?:\s*-\s*[\d.]+)?)\s*(?:Hz|rad/s)", c):
            out |= {float(v) for v in re.split(r"\s*-\s*", m.group(1)) if v not in ("", ".")}
    return out


def input_numbers(name):
    """Every number of the study's own TOML values (restated inputs need no check)."""
    import tomllib
    found = set()

    def walk(v):
        if isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            found.add(float(v))
    walk(tomllib.loads(text(name)))
    return found


@pytest.mark.parametrize("name", sorted(p.name for p in STUDIES.glob("*.toml")))
def test_every_stated_frequency_is_checked(name):
    unchecked = comment_frequencies(name) - CHECKED.get(name, set()) - input_numbers(name)
    assert not unchecked, f"{name}: stated frequencies without a check: {sorted(unchecked)}"


# --------------------------------------------------------------------------- the rest
def test_blade_shroud_contact_stuck_first_flap_mode():
    """'the stuck first flap mode is 497.6 Hz on this mesh ... and 403.6 Hz on the
    quick mesh': the unreduced blade with every node pair stuck (ku, kv per node)."""
    full, quick = stated("blade_shroud_contact.toml",
                         r"stuck first flap mode is ([\d.]+) Hz on this mesh .* and ([\d.]+) Hz\n# on the quick mesh")
    for q, f in ((False, full), (True, quick)):
        sc = load_study(STUDIES / "blade_shroud_contact.toml", quick=q).scene
        assert stuck_flap_hz(sc, 30.0) == pytest.approx(f, abs=0.05), q


def stuck_flap_hz(scene, preload):
    """First natural frequency [Hz] of the unreduced blade with every contact stuck."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    from pipeline.model.build import blade_contact_maps, blade_elements
    from pipeline.model.blade_cache import blade_model
    blade = blade_model(scene.structure)
    Bt, Bn, _ = blade_contact_maps(scene)
    el = blade_elements(scene, {"preload": preload})
    K = blade.K + Bt.T @ sp.diags(el.ku) @ Bt + Bn.T @ sp.diags(el.kv) @ Bn
    w2 = spla.eigsh(K.tocsc(), 1, blade.M.tocsc(), sigma=0, which="LM")[0]
    return float(hz(np.sqrt(w2[0])))


def test_accuracy_cost_blade_meshes_share_the_stuck_flap_mode():
    """'the stuck first flap mode: 500.1 / 495.7 / 494.8 / 494.4 Hz on the meshes
    2x1x3, 4x1x6, 6x1x9, 8x2x12' (per-face contacts at 50 N)."""
    from dataclasses import replace
    m = re.search(r"stuck first flap mode: ([\d./ ]+) Hz on the meshes ([\dx, ]+),\n# ([\dx, ]+)",
                  text("accuracy_cost.toml"))
    freqs = [float(v) for v in m.group(1).split("/")]
    meshes = [tuple(int(n) for n in v.split("x"))
              for v in (m.group(2) + "," + m.group(3)).replace(" ", "").split(",") if v]
    (case,) = [c for c in load_study(STUDIES / "accuracy_cost.toml").cases
               if getattr(c.scene.structure, "params", None) is not None]
    for counts, f in zip(meshes, freqs, strict=True):
        p = replace(case.scene.structure.params, **dict(zip(("n_chord", "n_thick", "n_span"), counts)))
        sc = replace(case.scene, structure=replace(case.scene.structure, params=p))
        assert stuck_flap_hz(sc, case.preload) == pytest.approx(f, abs=0.05), counts


def test_shrouded_disk_mistuned_quick_window_holds_the_tuned_peak():
    from pipeline.study.execution.mistuned import tuned_reference
    (f,) = stated("shrouded_disk_mistuned.toml", r"around the tuned peak, ([\d.]+) Hz")
    st = load_study(STUDIES / "shrouded_disk_mistuned.toml", quick=True)
    t = tuned_reference(st, {"preload": st.sweep.axes["preload"][0]}, ["response.y"])
    a = np.where(t.converged, t.amplitude["response.y"], -np.inf)
    assert t.frequency[int(np.argmax(a))] == pytest.approx(f, abs=0.05)


def test_disk_nonlinear_modes_nd6_starts_at_the_stated_frequency():
    """'ND 6: 498.0 Hz -> ...': the first backbone point (0.01 times the slip onset) of
    the ND 6 mode, one Newton solve of the EPMC equations (the quick run has ND 3, 12)."""
    from pipeline.solve.nonlinear_modes import epmc
    from pipeline.solve.nonlinear_modes.backbone import newton
    from pipeline.solve.nonlinear_modes.epmc import onset_amplitude

    study = load_study(STUDIES / "disk_nonlinear_modes.toml")
    mp = epmc.mode_problem(study.response.system({"preload": 2.0, "eo": 6}), 3)
    y, _, ok = newton(mp, epmc.linear_guess(mp), np.log10(0.01 * onset_amplitude(mp)), 1e-9)
    assert ok.converged
    f0 = stated("disk_nonlinear_modes.toml", r"ND 6: +([\d.]+) Hz")[0]
    assert y[-2] / (2 * np.pi) == pytest.approx(f0, abs=0.05)
