"""Check a study dataset (netCDF) against the pipeline's dataset contract.

    python -m pipeline.study.datasets.conformance FILE.nc [FILE.nc ...]

prints one line per problem and exits 1 if there are any, else one summary line
per file and exit 0; a file that is missing or not netCDF is one line and exit 2.
`problems(path)` is the same check as a function (the `check` command and the
tests call it).

The contract (studies/README.md, section Dataset), as checked here:

- global attributes `title`, `study`, `pipeline_version`, `created` and
  `Conventions = "CF-1.10"`, and for response datasets also `harmonics` and
  `force_evaluation`;
- every variable and coordinate has a `long_name`, every floating-point one
  `units`, every dimension a coordinate;
- `frequency` is a non-index coordinate on (sweeps..., point) in rad/s or Hz,
  so that `ds.amplitude.sel(preload=10, dof="u").plot(x="frequency")` works;
  the sweep axes are the other dimensions of `frequency`;
- `amplitude` (sweeps..., [sector,] point, dof), `harmonic_amplitude` (...,
  harmonic), `converged` and `stable` (sweeps..., point), `peak_amplitude` and
  `peak_frequency` (sweeps..., [sector,] dof);
- `dof` labels are DOF names: a sector is the `sector` dimension (integers
  0 ... N-1), never encoded in a label such as "x1@4";
- `harmonic` is 0 ... H with H the `harmonics` attribute;
- every converged point has a finite frequency and amplitudes; amplitudes are
  not negative; `peak_amplitude` is the largest converged amplitude (of the points
  inside the attribute `frequency_range`, where given: a branch may be followed
  beyond it) and `peak_frequency` the frequency of that point;
- `stable` is 1 (stable), 0 (unstable) or NaN (not computed), says so in
  `flag_meanings` or `comment`, is never 1 at a point that did not converge, and
  holds no value at all where its `stability_computed` attribute is 0;
- where present, `stability_method` (sweeps..., point) is -1 (not computed) exactly
  where `stable` is NaN, else 0 (Hill), 1 (Floquet), 2 (monodromy along the
  harmonic-balance orbit), 3 (propagated from the decided points of its stretch
  between two folds) or 4 (the fold rule: a decided end of the branch flipped at
  every fold), 3 and 4 with a NaN `max_multiplier`, with `flag_values` and
  `flag_meanings`; `max_multiplier` is NaN where no method decided and, where
  given, agrees with `stable` (1 iff the multiplier is at most 1 + 1e-6);
  `bifurcation_type` is -1 (padding), 1 (fold), 2 (period doubling) or
  3 (Neimark-Sacker) with `flag_meanings`, and `bifurcation_frequency` is finite
  exactly where it is not -1;
- where present, `peak_complete` (sweeps...) is 0 or 1, 1 only for a case with
  converged points, and 0 with a `message` that says why the branch stopped.

The per-contact variables and the response coefficients: `contact_check`.

A modal dataset (global attribute `kind = "modes"`: eigenfrequencies, no
response curves) is held to the attribute, units and coordinate rules only; a
nonlinear modes dataset (`kind = "nonlinear_modes"`) to those and `mode_conformance`.
"""
from __future__ import annotations

import os
import sys

import numpy as np

from ...errors import UsageError
from .contact_conformance import check_contacts
from .mode_conformance import check_nonlinear_modes

CONVENTIONS = "CF-1.10"
FREQUENCY_UNITS = ("rad/s", "rad s-1", "Hz", "s-1", "1/s")
COMMON_ATTRS = ("title", "study", "pipeline_version", "created", "Conventions")
RESPONSE_ATTRS = ("harmonics", "force_evaluation")
SECTOR_SEPARATOR = "@"
RTOL = 1e-9          # peak_amplitude / peak_frequency against the per-point values


class UnreadableDataset(UsageError):
    """The file is missing or is not a netCDF dataset (one line naming the file)."""


def problems(path) -> list[str]:
    """One line per departure of the dataset at `path` from the contract, each
    naming the file and the variable or attribute; [] when it conforms.

    `path` may also be an `xarray.Dataset` (named "<dataset>" in the lines).
    Raises UnreadableDataset (a UsageError) when the file is missing or not netCDF."""
    return _check(path)[0]


def _check(path):
    """(problems, one-line summary) of a file or an in-memory dataset."""
    # deferred: xarray (slow import), only when a dataset is checked
    import xarray as xr

    if isinstance(path, xr.Dataset):
        return _check_dataset(path, "<dataset>")
    name = os.fspath(path)
    if not os.path.isfile(name):
        raise UnreadableDataset(f"{name}: no such file")
    try:
        with xr.open_dataset(name, engine="netcdf4") as ds:
            ds = ds.load()
    except Exception as exc:  # any reader failure is the one "not netCDF" line
        why = " ".join(str(exc).split())[:200]
        raise UnreadableDataset(f"{name}: not a readable netCDF dataset "
                                f"({type(exc).__name__}: {why})") from None
    return _check_dataset(ds, name)


def _check_dataset(ds, name):
    out = []

    def say(what):
        out.append(f"{name}: {what}")

    kind = str(ds.attrs.get("kind", "response"))
    _check_attributes(ds, kind, say)
    _check_variables(ds, say)
    if kind == "modes":
        n = ds.sizes.get("mode", 0)
        return out, f"{name}: ok: modal dataset, {n} modes"
    if kind == "nonlinear_modes":
        n = check_nonlinear_modes(ds, say)
        return out, f"{name}: ok: nonlinear modes, {n} converged backbone points"
    sweeps = _check_frequency(ds, say)
    if sweeps is None:
        return out, ""
    _check_required(ds, sweeps, say)
    _check_labels(ds, say)
    if not out:  # the value checks below need the layout above
        _check_values(ds, say)
        _check_stable(ds, say)
        if "stability_method" in ds.variables:
            _check_stability_method(ds, say)
        if "peak_complete" in ds.variables:
            _check_peak_complete(ds, say)
        check_contacts(ds, _converged(ds), say)
    npts = int(_converged(ds).sum()) if "converged" in ds else 0
    sectors = f", {ds.sizes['sector']} sectors" if "sector" in ds.dims else ""
    dofs = [str(d) for d in ds["dof"].values][:6] if "dof" in ds.coords else []
    return out, (f"{name}: ok: sweeps {list(sweeps) or 'none'}{sectors}, {npts} converged "
                 f"points, dofs {dofs}, H = {ds.attrs.get('harmonics')}")


def _check_attributes(ds, kind, say):
    needed = COMMON_ATTRS + (() if kind == "modes" else RESPONSE_ATTRS)
    for a in needed:
        if a not in ds.attrs:
            say(f"global attribute {a!r} is missing")
    conv = ds.attrs.get("Conventions")
    if conv is not None and conv != CONVENTIONS:
        say(f"global attribute 'Conventions' is {conv!r}, expected {CONVENTIONS!r}")


def _check_variables(ds, say):
    """long_name everywhere, units on every number (floating-point, integer and flag
    values: "1" for counts, indices and flags), a coordinate per dimension."""
    for vname, var in ds.variables.items():
        what = "coordinate" if vname in ds.coords else "variable"
        if "long_name" not in var.attrs:
            say(f"{what} {vname!r} has no long_name attribute")
        if var.dtype.kind in "fciub" and "units" not in var.attrs:
            say(f"{what} {vname!r} holds numbers without a units attribute")
    for d in ds.dims:
        if d not in ds.coords:
            say(f"dimension {d!r} has no coordinate (give it index values and a long_name)")


def _check_frequency(ds, say):
    """The sweep axes (the dims of `frequency` before `point`), or None if unusable."""
    if "frequency" not in ds.variables:
        say("variable 'frequency' is missing")
        return None
    f = ds["frequency"]
    if "frequency" in ds.dims:
        say("'frequency' is a dimension (an index): branches are multivalued in frequency; "
            "make it a non-index coordinate on (sweeps..., point)")
        return None
    if "frequency" in ds.data_vars:
        say("'frequency' is a data variable: make it a non-index coordinate on "
            "(sweeps..., point) so that amplitude.plot(x='frequency') works")
    if not f.dims or f.dims[-1] != "point":
        say(f"'frequency' has dims {f.dims}: expected (sweeps..., 'point')")
        return None
    units = f.attrs.get("units")
    if units is not None and units not in FREQUENCY_UNITS:
        say(f"'frequency' units {units!r}: expected one of {', '.join(FREQUENCY_UNITS)}")
    sweeps = f.dims[:-1]
    for d in sweeps:
        if d in ds.coords and ds[d].dtype.kind in "iu" and "units" not in ds[d].attrs:
            say(f"sweep coordinate {d!r} has no units attribute")
    return sweeps


def _check_required(ds, sweeps, say):
    """The required variables with their dimensions (sector optional where per sector)."""
    sw = tuple(sweeps)
    layout = {"amplitude": ("point", "dof"), "harmonic_amplitude": ("point", "dof", "harmonic"),
              "converged": None, "stable": None,
              "peak_amplitude": ("dof",), "peak_frequency": ("dof",)}
    for vname, tail in layout.items():
        if vname not in ds.variables:
            say(f"variable {vname!r} is missing")
            continue
        dims = ds[vname].dims
        allowed = [sw + ("point",)] if tail is None else [sw + tail, sw + ("sector",) + tail]
        if dims not in allowed:
            say(f"variable {vname!r} has dims {dims}: expected "
                + " or ".join(str(a) for a in allowed))
    if "peak_frequency" in ds and "frequency" in ds.variables:
        fu, pu = ds["frequency"].attrs.get("units"), ds["peak_frequency"].attrs.get("units")
        if fu is not None and pu is not None and fu != pu:
            say(f"variable 'peak_frequency' has units {pu!r}, 'frequency' has {fu!r}")
    if "mistuning_factor" in ds and "sector" not in ds["mistuning_factor"].dims:
        say("variable 'mistuning_factor' lacks the 'sector' dimension")


def _check_labels(ds, say):
    """dof names without sector numbers, harmonic 0..H, sector 0..N-1."""
    if "dof" in ds.coords:
        labels = [str(x) for x in ds["dof"].values]
        for lab in labels:
            if SECTOR_SEPARATOR in lab:
                d, _, j = lab.rpartition(SECTOR_SEPARATOR)
                say(f"dof label {lab!r} encodes a sector: report per-sector results on a "
                    f"'sector' dimension (sector {j}, dof {d!r})")
        if len(set(labels)) != len(labels):
            say("coordinate 'dof' has repeated labels")
    if "harmonic" in ds.coords:
        h = ds["harmonic"].values
        if not np.array_equal(h, np.arange(h.size)):
            say(f"coordinate 'harmonic' is {h.tolist()}: expected 0 ... H")
        elif "harmonics" in ds.attrs and int(ds.attrs["harmonics"]) != h.size - 1:
            say(f"global attribute 'harmonics' is {ds.attrs['harmonics']}, coordinate "
                f"'harmonic' ends at {h.size - 1}")
    if "sector" in ds.coords:
        s = ds["sector"].values
        n = ds.attrs.get("sectors")
        if s.dtype.kind not in "iu":
            say("coordinate 'sector' must hold integer sector numbers")
        elif (s < 0).any() or len(set(s.tolist())) != s.size or (n is not None and (s >= n).any()):
            say(f"coordinate 'sector' is {s.tolist()}: expected distinct numbers 0 ... "
                f"{'N-1' if n is None else int(n) - 1}")


def _converged(ds):
    c = ds["converged"]
    return c.fillna(0).astype(bool) if c.dtype.kind == "f" else c.astype(bool)


def _check_values(ds, say):
    """Finite values at converged points, amplitudes >= 0, peaks equal to the points."""
    conv = _converged(ds)
    if ds["converged"].dtype.kind not in "biu":
        say("variable 'converged' must be a flag (boolean)")
    if int(conv.sum()) == 0:
        say("no converged point")
        return
    f, amp = ds["frequency"], ds["amplitude"]
    if bool((f.isnull() & conv).any()):
        say("'frequency' is NaN at a converged point")
    for vname in ("amplitude", "harmonic_amplitude"):
        if bool((ds[vname].isnull() & conv).any()):
            say(f"variable {vname!r} is NaN at a converged point")
        if bool((ds[vname] < 0).any()):
            say(f"variable {vname!r} is negative somewhere")
    rng = ds.attrs.get("frequency_range")   # the branch followed beyond it: not its peak
    if rng is not None:
        conv = conv & (f >= np.min(rng)) & (f <= np.max(rng))
    a = amp.where(conv)
    pk = a.max("point")
    peak = ds["peak_amplitude"]
    close = abs(pk - peak) <= RTOL * (1e-300 + abs(pk))
    if bool((~close & ~(pk.isnull() & peak.isnull())).any()):
        say("variable 'peak_amplitude' differs from the largest 'amplitude' over converged points"
            + (" inside frequency_range" if rng is not None else ""))
        return
    tol = RTOL * abs(peak)
    at_peak = conv & (abs(a - peak) <= tol) & (abs(f - ds["peak_frequency"])
                                               <= RTOL * abs(ds["peak_frequency"]))
    if bool((~at_peak.any("point") & peak.notnull()).any()):
        say("variable 'peak_frequency' is not the frequency of the point of 'peak_amplitude'")


def _check_peak_complete(ds, say):
    """`peak_complete`: a 0/1 flag, 1 only where the case has converged points, 0 with
    a message (module docstring)."""
    pc = ds["peak_complete"].values
    if not np.isin(pc.astype(float), (0.0, 1.0)).all():
        say("variable 'peak_complete' holds values other than 0 and 1")
        return
    has = _converged(ds).any("point").values
    if (pc.astype(bool) & ~has).any():
        say("variable 'peak_complete' is 1 for a case without converged points")
    if "message" in ds.variables:
        msg = np.vectorize(lambda m: len(str(m).strip()) > 0)(ds["message"].values)
        if (~pc.astype(bool) & has & ~msg).any():
            say("variable 'peak_complete' is 0 where 'message' does not say why the branch "
                "stopped")


def _check_stable(ds, say):
    """1 / 0 where computed, NaN where not, and said so."""
    st = ds["stable"]
    if st.dtype.kind in "biu":
        say("variable 'stable' is a boolean/integer flag: it cannot mark points where "
            "stability was not computed; store 1 (stable), 0 (unstable), NaN (not computed)")
        return
    vals = st.values
    known = np.isnan(vals) | (vals == 0) | (vals == 1)
    if not known.all():
        say("variable 'stable' holds values other than 1 (stable), 0 (unstable) and NaN")
    if bool(((st == 1) & ~_converged(ds)).any()):
        say("variable 'stable' is 1 at a point that did not converge (no stability there: NaN)")
    if st.attrs.get("stability_computed", 1) == 0 and bool(st.notnull().any()):
        say("variable 'stable' has values although its stability_computed attribute is 0")
    if "flag_meanings" not in st.attrs and "comment" not in st.attrs:
        say("variable 'stable' has neither flag_meanings nor comment saying what 1, 0 and "
            "NaN mean")


MULTIPLIER_TOL = 1e-6   # a multiplier this close to 1 may be called stable (marginal)


def _check_stability_method(ds, say):
    """The deciding method, the largest multiplier and the bifurcations agree with
    `stable`."""
    need = ("max_multiplier", "bifurcation_frequency", "bifurcation_type")
    missing = [v for v in need if v not in ds.variables]
    if missing:
        say(f"variable 'stability_method' comes without {', '.join(map(repr, missing))}")
        return
    m, st, mult = ds["stability_method"], ds["stable"], ds["max_multiplier"]
    for v in ("stability_method", "bifurcation_type"):
        if not {"flag_values", "flag_meanings"} <= set(ds[v].attrs):
            say(f"variable {v!r} lacks flag_values / flag_meanings")
    if not np.isin(m.values, (-1, 0, 1, 2, 3, 4)).all():
        say("variable 'stability_method' holds values other than -1, 0, 1, 2, 3 and 4")
    if bool(((m == -1) != st.isnull()).any()):
        say("variable 'stability_method' is not -1 exactly where 'stable' is NaN")
    if bool((((m == -1) | (m >= 3)) & mult.notnull()).any()):
        say("variable 'max_multiplier' has a value where no method decided (or where the "
            "flag was propagated or ruled by folds)")
    agree = (st == 1) == (mult <= 1 + MULTIPLIER_TOL)
    if bool((~agree & (m >= 0) & mult.notnull()).any()):
        say("variable 'max_multiplier' contradicts 'stable' (stable iff max |mu| <= 1)")
    bt = ds["bifurcation_type"]
    if not np.isin(bt.values, (-1, 1, 2, 3)).all():
        say("variable 'bifurcation_type' holds values other than -1, 1, 2 and 3")
    if bool(((bt == -1) != ds["bifurcation_frequency"].isnull()).any()):
        say("variable 'bifurcation_frequency' is not finite exactly where 'bifurcation_type' "
            "is not -1")


def main(argv=None) -> int:
    """`python -m pipeline.study.datasets.conformance FILE.nc ...`: 0 all conform, 1 problems
    found, 2 a file is missing or not netCDF (or no file given)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__.strip().split("\n\n")[0] + "\n\n"
              "usage: python -m pipeline.study.datasets.conformance FILE.nc [FILE.nc ...]")
        return 0 if argv else 2
    found, unreadable, summaries = [], False, []
    for path in argv:
        try:
            bad, summary = _check(path)
        except UnreadableDataset as exc:
            print(exc)
            unreadable = True
            continue
        found += bad
        if not bad:
            summaries.append(summary)
    for line in found:
        print(line)
    if unreadable:
        return 2
    if found:
        return 1
    for line in summaries:
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
