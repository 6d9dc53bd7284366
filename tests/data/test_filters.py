"""pinid.data.filters against scipy.signal and against exact answers; preprocessing without scipy.signal."""

from __future__ import annotations

import subprocess
import sys
from fractions import Fraction
from math import factorial

import numpy as np
import pytest
from scipy import ndimage, signal

import pinid.data.preprocess as preprocess
from pinid.data.dataset import Dataset
from pinid.data.filters import butter_sos, default_padlen, filtfilt_sos, savgol, savgol_matrix
from pinid.excitation.trajectory import FourierTrajectory

RATIOS = np.geomspace(1e-4, 0.39, 23)  # cut-off / sample rate
EPS = np.finfo(float).eps


def filtfilt_tolerance(sos: np.ndarray, n: int, padlen: int) -> float:
    """Relative difference two zero-phase filters may show from round-off alone (times max|x|).

    A rounding error e made at one sample inside a section's recursion 1/A(z) reaches the output at most
    e·‖h‖₁, h that recursion's impulse response over the n + 2·padlen samples filtered (poles near z = 1:
    large ‖h‖₁).  So 4·eps·Σ‖h‖₁ over the sections: two passes (forward, backward), two implementations
    (pinid's banded solves, scipy's direct form).  Measured on these tests: at most 1.5·eps·Σ‖h‖₁."""
    impulse = np.zeros(n + 2 * padlen)
    impulse[0] = 1.0
    gain = sum(np.abs(signal.sosfilt([[1.0, 0.0, 0.0, *s[3:]]], impulse)).sum() for s in np.asarray(sos))
    return 4 * EPS * gain


def edge_fit_tolerance(window: int, polyorder: int) -> float:
    """Relative round-off of a Savitzky–Golay edge (times max|output|): scipy fits the edge polynomial with
    numpy's polyfit on the offsets 0..window−1, columns scaled, so a fit is backward stable to
    eps·cond(V_scaled); 4×: the fit and its evaluation, in both implementations (measured: ≤ 0.25·eps·cond)."""
    V = np.vander(np.arange(window, dtype=float), polyorder + 1)
    return 4 * EPS * np.linalg.cond(V / np.linalg.norm(V, axis=0))


def signals(n: int, columns: int = 3, seed: int = 0) -> np.ndarray:
    """Sines of several periods on offsets, plus noise: (n, columns)."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)[:, None]
    j = np.arange(columns)[None, :]
    return (j + 1) * np.sin(2 * np.pi * k * (j + 1) / 977) + 0.5 * j - 0.3 + 0.01 * rng.normal(size=(n, columns))


@pytest.mark.parametrize("order", range(1, 11))
def test_butter_sos_is_scipys_design_section_by_section(order):
    for fs in (1000.0, 5000.0):
        for ratio in RATIOS:
            ours = butter_sos(order, ratio * fs, fs)
            ref = signal.butter(order, ratio * fs, btype="low", fs=fs, output="sos")
            assert ours.shape == ref.shape
            # each coefficient is a product of at most ``order`` factors (poles, zeros, gain) computed by the
            # same formulas as scipy's: one rounding per factor at most (measured: bit for bit)
            assert np.max(np.abs(ours - ref)) <= order * EPS * np.max(np.abs(ref)), (order, ratio)


@pytest.mark.parametrize("order", [1, 2, 3, 4, 7, 10])
def test_butter_sos_has_unit_dc_gain_and_half_power_at_the_cutoff(order):
    fs = 1000.0
    for cutoff in (0.5, 10.0, 123.0, 380.0):
        sos = butter_sos(order, cutoff, fs)
        for f, power in ((0.0, 1.0), (cutoff, 0.5)):
            z = np.exp(-2j * np.pi * f / fs)  # z⁻¹
            h = np.prod([(b0 + b1 * z + b2 * z * z) / (a0 + a1 * z + a2 * z * z) for b0, b1, b2, a0, a1, a2 in sos])
            # each polynomial: three terms, each rounded (coefficient and product), relative to its value (it
            # cancels near a pole: poles near z = 1 at a low cut-off); |h|² doubles it (measured: ≤ 0.13 of it)
            terms = [np.abs(c).sum() / abs(c[0] + c[1] * z + c[2] * z * z) for row in sos for c in (row[:3], row[3:])]
            assert abs(abs(h) ** 2 - power) <= 2 * power * 3 * EPS * sum(terms), (order, cutoff, f)


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 8])
def test_filtfilt_sos_is_scipys_sosfiltfilt_with_odd_padding(order):
    x = signals(700)
    for ratio in RATIOS[::3]:
        sos = signal.butter(order, ratio, fs=1.0, output="sos")
        for padlen in (0, 1, default_padlen(sos), 300, 699):
            for a in (x, x[:, 1]):  # 2-D and 1-D
                ref = signal.sosfiltfilt(sos, a, axis=0, padtype="odd", padlen=padlen)
                ours = filtfilt_sos(sos, a, padlen)
                assert ours.shape == a.shape
                tol = filtfilt_tolerance(sos, len(a), padlen)
                assert np.max(np.abs(ours - ref)) <= tol * np.max(np.abs(a)), (order, ratio, padlen)


def test_filtfilt_sos_on_short_signals_near_padlen():
    sos = signal.butter(4, 0.05, fs=1.0, output="sos")
    padlen = default_padlen(sos)
    for n in (padlen + 1, padlen + 2, padlen + 5):
        x = signals(n, 2, seed=n)
        ref = signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)
        tol = filtfilt_tolerance(sos, n, padlen)
        assert np.max(np.abs(filtfilt_sos(sos, x, padlen) - ref)) <= tol * np.max(np.abs(x))
    with pytest.raises(ValueError, match="padlen"):
        filtfilt_sos(sos, signals(padlen, 2), padlen)


def test_filtfilt_sos_is_accurate_with_poles_near_one_on_long_signals():
    """1 Hz at 5 kHz, order 4 (poles within 1e-3 of z = 1), 60 000 samples, padded over the settling time."""
    fs, n, padlen = 5000.0, 60_000, 3000
    t = np.arange(n) / fs
    x = np.column_stack(
        [np.sin(2 * np.pi * 0.3 * t) + 2.0, 0.5 * np.cos(2 * np.pi * 0.05 * t) - 1.0, signals(n, 1)[:, 0]]
    )
    for order in (3, 4, 8):
        sos = signal.butter(order, 1.0, fs=fs, output="sos")
        ref = signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)
        ours = filtfilt_sos(butter_sos(order, 1.0, fs), x, padlen)
        assert np.max(np.abs(ours - ref) / np.max(np.abs(x), axis=0)) <= filtfilt_tolerance(sos, n, padlen), order


def test_filtfilt_sos_passes_a_constant_unchanged():
    """To round-off amplified by poles near z = 1 (scipy: 1e-11 here): one implementation, two passes, so half
    :func:`filtfilt_tolerance`'s allowance for two."""
    sos = butter_sos(6, 2.0, 1000.0)
    x = np.full((500, 2), [3.25, -1.5])
    assert np.max(np.abs(filtfilt_sos(sos, x, 200) - x)) <= filtfilt_tolerance(sos, 500, 200) / 2 * 3.25


def exact_savgol_row(window: int, polyorder: int, deriv: int) -> np.ndarray:
    """Centre weights of the Savitzky–Golay filter (unit step) in exact rational arithmetic."""
    half = window // 2
    xs = range(-half, half + 1)
    n = polyorder + 1
    rows = [[Fraction(sum(x ** (i + j) for x in xs)) for j in range(n)] + [Fraction(int(i == deriv))] for i in range(n)]
    for c in range(n):  # Gauss–Jordan on the normal equations
        p = next(r for r in range(c, n) if rows[r][c] != 0)
        rows[c], rows[p] = rows[p], rows[c]
        for r in range(n):
            if r != c and rows[r][c] != 0:
                f = rows[r][c] / rows[c][c]
                rows[r] = [a - f * b for a, b in zip(rows[r], rows[c])]
    z = [rows[i][n] / rows[i][i] for i in range(n)]
    return np.array([float(factorial(deriv) * sum(z[j] * Fraction(x) ** j for j in range(n))) for x in xs])


@pytest.mark.parametrize("window", [5, 9, 61, 301])
def test_savgol_weights_are_the_exact_least_squares_ones(window):
    for polyorder in (2, 3, 5)[: 3 if window > 5 else 2]:
        for deriv in (0, 1, 2):
            exact = exact_savgol_row(window, polyorder, deriv)
            ours = savgol_matrix(window, polyorder, deriv, 1.0)[window // 2]
            # the pseudo-inverse of the centred, scaled Vandermonde is backward stable: eps·cond(V) in the
            # 2-norm, √window from it to the largest weight (measured: ≤ 0.43 of it)
            u = (np.arange(window) - window // 2) / (window // 2)
            cond = np.linalg.cond(np.vander(u, polyorder + 1, increasing=True))
            tol = EPS * cond * np.sqrt(window) * np.max(np.abs(exact))
            assert np.max(np.abs(ours - exact)) <= tol, (polyorder, deriv)


@pytest.mark.parametrize("window", [5, 7, 9, 15, 21, 31])
def test_savgol_is_scipys_savgol_filter_with_interp_edges(window):
    """Same filter as scipy's, within the rounding error of scipy's own weights.

    scipy solves for the weights by least squares on the *unscaled* Vandermonde matrix V of the
    offsets -half..half (and numpy's polyfit for the edges), which is backward stable: the weights
    come out with a relative error of about eps·cond(V), so a filtered sample is off by at most about
    eps·cond(V)·‖w‖₁·max|x| (‖w‖₁ the exact weights' 1-norm, per deltaᵈᵉʳⁱᵛ), times a small factor
    for the window's accumulation. cond(V) grows like half^polyorder (5e5 at 31 samples, quintic),
    so the tolerance follows it; ours are checked against the exact rational weights to window·eps of the
    same yardstick, with no such factor (pinid's Vandermonde is centred and scaled)."""
    h = 1e-3
    half = window // 2
    eps = np.finfo(float).eps
    for n in (window, window + 1, 400):
        x = signals(n, 3, seed=window)
        for polyorder in (2, 3, 5):
            if polyorder >= window:
                continue
            cond = np.linalg.cond(np.vander(np.arange(-half, half + 1.0), polyorder + 1, increasing=True))
            for deriv in (0, 1, 2):
                exact = exact_savgol_row(window, polyorder, deriv) / h**deriv
                for a in (x, x[:, 2]):
                    yardstick = np.sum(np.abs(exact)) * np.max(np.abs(a))  # what one output sample is made of
                    ref = signal.savgol_filter(a, window, polyorder, deriv=deriv, delta=h, axis=0, mode="interp")
                    ours = savgol(a, window, polyorder, deriv, h)
                    assert ours.shape == a.shape
                    assert np.max(np.abs(ours - ref)) <= 4 * window * eps * cond * yardstick, (n, polyorder, deriv)
                    interior = ndimage.correlate1d(a, exact, axis=0, mode="constant")[half : n - half]
                    # the weights' error and the window-long sum, one rounding per sample (measured: ≤ 0.28 of it)
                    tol = window * EPS * yardstick
                    assert np.max(np.abs(ours[half : n - half] - interior)) <= tol, (n, polyorder, deriv)


@pytest.mark.parametrize("window", [61, 301, 601])
def test_savgol_long_windows_differentiate_polynomials_exactly_and_keep_scipys_edges(window):
    """Long windows (FFT path): exact on a quintic, edges as scipy's (polyfit) edges; the interior is
    checked against the exact weights, where scipy's lose digits (5e-9 at 301 samples)."""
    h = 2e-4
    n = 3000
    t = np.arange(n) * h - 0.2
    c = [0.3, -1.2, 2.0, 0.7, -3.0, 1.5]
    q = sum(ck * t**k for k, ck in enumerate(c))
    dq = sum(k * ck * t ** (k - 1) for k, ck in enumerate(c) if k >= 1)
    ddq = sum(k * (k - 1) * ck * t ** (k - 2) for k, ck in enumerate(c) if k >= 2)
    size = 1 << int(np.ceil(np.log2(n + window - 1)))  # the FFT's length (windows over 31 samples)
    rounded = sum(abs(ck) * np.abs(t) ** k for k, ck in enumerate(c))  # q's own round-off, over eps
    for deriv, truth in ((0, q), (1, dq), (2, ddq)):
        # q's round-off through the derivative operator (its ∞-norm, edge rows included), the FFT's
        # round-off growing as log2 of its length, forward and back (measured: ≤ 0.06 of it)
        gain = np.abs(savgol_matrix(window, 5, deriv, h)).sum(axis=1).max()
        tol = 2 * np.log2(size) * EPS * gain * np.max(rounded)
        assert np.max(np.abs(savgol(q, window, 5, deriv, h) - truth)) <= tol, deriv
    x = signals(n, 2)
    half = window // 2
    for deriv in (0, 1, 2):
        ours = savgol(x, window, 5, deriv, h)
        ref = signal.savgol_filter(x, window, 5, deriv=deriv, delta=h, axis=0, mode="interp")
        scale = np.max(np.abs(ref))
        edges = np.r_[0:half, n - half : n]
        assert np.max(np.abs(ours[edges] - ref[edges])) <= edge_fit_tolerance(window, 5) * scale, deriv
        weights = exact_savgol_row(window, 5, deriv) / h**deriv
        exact = ndimage.correlate1d(x, weights, axis=0, mode="constant")
        # the weights' error and the window-long sum, as for short windows; the FFT's own round-off is below
        # it here (measured: ≤ 0.05 of it)
        tol = window * EPS * np.sum(np.abs(weights)) * np.max(np.abs(x))
        assert np.max(np.abs(ours[half:-half] - exact[half:-half])) <= tol, deriv


TRAJ = FourierTrajectory(
    ["hip", "knee"],
    2 * np.pi * 0.4,
    [0.3, -0.5],
    [[0.3, 0.1, 0.05], [0.2, -0.1, 0.04]],
    [[0.1, 0, 0.02], [0.05, 0.1, -0.03]],
)


def twin(fs: float, velocity: bool) -> Dataset:
    """A noise-free recording: Fourier motion and a torque made from it."""
    t = np.arange(int(8 * fs)) / fs
    q, dq, ddq = TRAJ.evaluate(t)
    return Dataset(
        t=t, q=q, joints=["hip", "knee"], dq=dq if velocity else None, tau=2.0 * ddq + 5.0 * np.sin(q) + 0.3 * dq
    )


def scipy_prepare(ds: Dataset, monkeypatch, **options) -> Dataset:
    """prepare() as it was: scipy.signal's butter and sosfiltfilt, Savitzky–Golay by scipy's method
    (correlation in the interior, polyfit edges) with the exact weights, scipy's own being off by up to
    ~1e-8 in the second derivative at these windows."""

    def scipy_savgol(a, window, polyorder, deriv, delta):
        edges = signal.savgol_filter(a, window, polyorder, deriv=deriv, delta=delta, axis=0, mode="interp")
        inner = ndimage.correlate1d(a, exact_savgol_row(window, polyorder, deriv) / delta**deriv, axis=0)
        half = window // 2
        edges[half:-half] = inner[half:-half]
        return edges

    with monkeypatch.context() as m:
        m.setattr(preprocess, "butter_sos", lambda order, cutoff, fs: signal.butter(order, cutoff, fs=fs, output="sos"))
        m.setattr(preprocess, "filtfilt_sos", lambda sos, a, pad: signal.sosfiltfilt(sos, a, axis=0, padlen=pad))
        m.setattr(preprocess, "savgol", scipy_savgol)
        return preprocess.prepare(ds, options)


def prepare_tolerances(ds: Dataset, prepared: Dataset) -> dict[str, float]:
    """What prepare()'s outputs may differ by between the two paths, from round-off: the low-pass's
    (:func:`filtfilt_tolerance` of the filter and padding prepare() used, times max|input|); for a
    derivative, the two filters' actual difference on the whole (untrimmed) signal it differentiates,
    times the derivative's gain (the ∞-norm of the Savitzky–Golay operator, edge rows included, or 1/h and
    4/h² for central differences), plus the edges' own fit (scipy's polyfit: :func:`edge_fit_tolerance`)."""
    used = prepared.meta["preprocess"]
    fs, cutoff, order, window = used["sample_rate"], used["cutoff"], used["order"], used["savgol_window"]
    sos = butter_sos(order, cutoff, fs)
    pad = int(min(ds.n - 1, max(default_padlen(sos), np.ceil(preprocess.default_trim(fs, cutoff, order) * fs))))
    filtered = filtfilt_tolerance(sos, ds.n, pad)

    def difference(x: np.ndarray) -> float:  # the two low-passes' difference on what is differentiated
        return np.max(np.abs(filtfilt_sos(sos, x, pad) - signal.sosfiltfilt(sos, x, axis=0, padlen=pad)))

    def derived(out: np.ndarray, deriv: int, upstream: float) -> float:
        if window is None:  # central differences: np.gradient's 1/h, the second difference's 4/h²
            return (fs if deriv == 1 else 4 * fs**2) * upstream
        gain = np.abs(savgol_matrix(window, preprocess.SAVGOL_POLYORDER, deriv, 1.0 / fs)).sum(axis=1).max()
        return gain * upstream + edge_fit_tolerance(window, preprocess.SAVGOL_POLYORDER) * np.max(np.abs(out))

    tol = {name: filtered * np.max(np.abs(getattr(ds, name))) for name in ("q", "tau")}
    if ds.dq is not None:  # the measured velocity filtered, the acceleration its derivative
        tol["dq"] = filtered * np.max(np.abs(ds.dq))
        tol["ddq"] = derived(prepared.ddq, 1, difference(ds.dq))
    else:
        tol["dq"] = derived(prepared.dq, 1, difference(ds.q))
        tol["ddq"] = derived(prepared.ddq, 2, difference(ds.q))
    return tol


@pytest.mark.parametrize("fs", [200.0, 1000.0, 5000.0])
@pytest.mark.parametrize("velocity", [False, True])
def test_prepare_gives_what_the_scipy_signal_path_gave(fs, velocity, monkeypatch):
    ds = twin(fs, velocity)
    for options in ({}, {"cutoff": 3.0, "order": 3}, {"differentiation": "central"}):
        new = preprocess.prepare(ds, options)
        old = scipy_prepare(ds, monkeypatch, **options)
        assert new.meta == old.meta
        np.testing.assert_array_equal(new.t, old.t)
        tol = prepare_tolerances(ds, new)
        for name in ("q", "dq", "ddq", "tau"):
            a, b = getattr(new, name), getattr(old, name)
            assert np.max(np.abs(a - b)) <= tol[name], (name, options)


def test_resampling_anti_alias_is_scipys(monkeypatch):
    ds = twin(1000.0, False)
    new, _ = preprocess.uniform_grid(ds, rate=250.0)
    with monkeypatch.context() as m:
        m.setattr(preprocess, "butter_sos", lambda order, cutoff, fs: signal.butter(order, cutoff, fs=fs, output="sos"))
        m.setattr(preprocess, "filtfilt_sos", lambda sos, a, pad: signal.sosfiltfilt(sos, a, axis=0))
        old, _ = preprocess.uniform_grid(ds, rate=250.0)
    anti_alias = butter_sos(8, 0.4 * 250.0, 1000.0)  # what uniform_grid filters with before the spline
    # the spline is linear in its data and amplifies a change of it at most ~1.5-fold on uniform knots: 2×
    tol = 2 * filtfilt_tolerance(anti_alias, ds.n, default_padlen(anti_alias))
    for name in ("q", "tau"):
        a, b = getattr(new, name), getattr(old, name)
        assert np.max(np.abs(a - b)) <= tol * np.max(np.abs(getattr(ds, name)))
    x = twin(1000.0, False).q
    sos = signal.butter(5, 20.0, fs=1000.0, output="sos")
    ref = signal.sosfiltfilt(sos, x, axis=0)
    tol = filtfilt_tolerance(sos, len(x), default_padlen(sos))
    assert np.max(np.abs(preprocess.lowpass(x, 1000.0, 20.0, order=5) - ref)) <= tol * np.max(np.abs(x))


def test_preprocessing_does_not_import_scipy_signal():
    """The default path (no resampling) loads neither scipy.signal nor scipy.stats nor scipy.interpolate."""
    code = """
import sys
import numpy as np
from pinid.data.dataset import Dataset
from pinid.data.preprocess import prepare
t = np.arange(3000) / 1000
q = np.column_stack([np.sin(t), np.cos(2 * t)])
out = prepare(Dataset(t=t, q=q, joints=["a", "b"], tau=q ** 2))
assert out.ddq is not None
print(sorted(m for m in ("scipy.signal", "scipy.stats", "scipy.interpolate") if m in sys.modules))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]", proc.stdout
