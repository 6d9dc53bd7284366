"""Digital filters for preprocessing, without scipy.signal (whose import costs more than the filtering).

:func:`butter_sos` designs a Butterworth low-pass in second-order sections, :func:`filtfilt_sos` runs it
forward and backward (zero phase), :func:`savgol` smooths or differentiates by Savitzky–Golay.  Each
gives what ``scipy.signal.butter(..., output="sos")``, ``sosfiltfilt(..., padtype="odd")`` and
``savgol_filter(..., mode="interp")`` give, to round-off; samples run along axis 0.  The recursions are
banded triangular solves in LAPACK (``dtbtrs``), the Savitzky–Golay interior a convolution (FFT for long
windows).  The Savitzky–Golay weights come from a centred, scaled Vandermonde: exact to ~1e-14, where
scipy's (unscaled) lose digits as the window grows (5e-9 relative at 301 samples, 5e-7 at 601).

Why beside scipy.signal (measured; docs/benchmarks.md, "Preprocessing without scipy.signal"):
``import scipy.signal`` took 0.44 s of a command (scipy 1.17 rewrites its functions' docstrings at
import and pulls scipy.stats); without it ``pinid identify --no-figures`` went 1.06 → 0.63 s on exo_leg.
Re-measured 2026-11-24 (scipy 1.17.1, 2 cores at load 4): 0.81 s, best of 5, after importing
pinid's preprocessing and estimators.  The price: the zero-phase filter is 1.6× slower than
``sosfiltfilt`` (order 4, 60 000 × 6 samples: 12 against 8 ms), far less than the import; Savitzky–Golay
is faster for long windows (301 samples: 7 against 51 ms).  tests/data/test_filters.py compares every
function with scipy.signal, to tolerances derived from the round-off of what is compared.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.blas import daxpy
from scipy.linalg.lapack import dtbtrs


def butter_sos(order: int, cutoff: float, fs: float) -> np.ndarray:
    """Digital Butterworth low-pass of ``order`` with −3 dB at ``cutoff`` [Hz] for sample rate ``fs`` [Hz]:
    second-order sections ``(n_sections, 6)`` rows ``[b0, b1, b2, 1, a1, a2]``, DC gain 1.

    Analog prototype poles, pre-warped, bilinear transform; sections paired as scipy.signal.zpk2sos
    ("nearest": each pole takes its nearest zeros, the poles closest to the unit circle last)."""
    wn = cutoff / (fs / 2)
    if not 0 < wn < 1:
        raise ValueError(f"cut-off {cutoff} Hz must lie in (0, fs/2 = {fs / 2}) Hz")
    m = np.arange(-order + 1, order, 2, dtype=float)
    analog = -np.exp(1j * np.pi * m / (2 * order)) * (4.0 * np.tan(np.pi * wn / 2))  # pre-warped, fs = 2
    gain = (4.0 * np.tan(np.pi * wn / 2)) ** order * np.real(1.0 / np.prod(4.0 - analog))
    poles = (4.0 + analog) / (4.0 - analog)  # bilinear transform; the zeros at infinity go to z = −1
    zeros = [-1.0] * order + [0.0] * (order % 2)  # odd order: a zero and a pole at the origin pad a pair
    poles = np.concatenate((poles, [0.0] * (order % 2)))
    real = np.abs(poles.imag) <= 100 * np.finfo(float).eps * np.abs(poles)
    upper = poles[~real & (poles.imag > 0)]
    remaining = list(upper[np.lexsort((upper.imag, upper.real))]) + sorted(poles[real].real)
    sos = np.zeros(((order + 1) // 2, 6))
    for si in range(len(sos) - 1, -1, -1):
        p1 = remaining.pop(int(np.argmin([abs(1 - abs(p)) for p in remaining])))
        if np.iscomplexobj(p1) and p1.imag != 0:
            a = [1.0, -2 * p1.real, (p1 * np.conj(p1)).real]
        else:
            reals = [i for i, p in enumerate(remaining) if np.imag(p) == 0]
            p2 = remaining.pop(reals[int(np.argmin([abs(1 - abs(remaining[i])) for i in reals]))])
            p1, p2 = np.real(p1), np.real(p2)
            a = [1.0, -(p1 + p2), p1 * p2]
        z1 = zeros.pop(int(np.argsort(np.abs(np.array(zeros) - p1))[0]))
        z2 = zeros.pop(int(np.argsort(np.abs(np.array(zeros) - p1))[0]))
        sos[si] = [1.0, -(z1 + z2), z1 * z2, *a]
    sos[0, :3] *= gain
    return sos


def _sos_initial_state(sos: np.ndarray) -> np.ndarray:
    """Steady-state initial conditions ``(n_sections, 2)`` of a cascade (transposed direct form II) for a
    unit step input, as scipy.signal.sosfilt_zi."""
    zi = np.empty((len(sos), 2))
    scale = 1.0
    for s, (b0, b1, b2, a0, a1, a2) in enumerate(sos):
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        steady = (b0 + b1 + b2) / (1.0 + a1 + a2)
        zi[s, 1] = b2 - a2 * steady
        zi[s, 0] = b1 - a1 * steady + zi[s, 1]
        zi[s] *= scale
        scale *= steady
    return zi


def _numerator(b: np.ndarray, v: np.ndarray, out: np.ndarray, forward: bool) -> None:
    """``out = B·v`` for the numerator ``b = (b0, b1, b2)`` along axis 0 of ``v`` (Fortran order), delayed
    forward or advanced backward, with the samples before the first (after the last) taken as zero:
    in-place BLAS axpys over the flattened columns, then the two rows where columns meet set right."""
    n = len(v)
    flat_v, flat_out = v.reshape(-1, order="F"), out.reshape(-1, order="F")
    np.multiply(v, b[0], out=out)
    for lag in (1, 2):
        if b[lag] != 0 and n > lag:
            daxpy(
                flat_v, flat_out, n=flat_v.size - lag, a=b[lag], offx=0 if forward else lag, offy=lag if forward else 0
            )
    edge = [0, 1] if forward else [n - 1, n - 2]
    step = -1 if forward else 1
    out[edge[0]] = b[0] * v[edge[0]]
    if n > 1:
        out[edge[1]] = b[0] * v[edge[1]] + b[1] * v[edge[1] + step]


def _pass(sos: np.ndarray, zi: np.ndarray, v: np.ndarray, spare: np.ndarray, band: np.ndarray, forward: bool):
    """The cascade ``sos`` run over ``v`` (samples × columns, Fortran order) forward, or backward from the
    last sample, each section started from the steady state ``zi · v[first]``.  Each second-order section
    is the banded triangular Toeplitz system ``A·y = B·x + (initial state in the first two rows)``, solved
    in LAPACK (``dtbtrs``, all columns at once).  ``v``, ``spare`` and ``band`` (3 × samples) are
    overwritten; the result is ``v`` or ``spare``."""
    first = v[0].copy() if forward else v[-1].copy()
    rhs = spare
    for section, state in zip(sos, zi):
        b0, b1, b2, a0, a1, a2 = section / section[3]
        _numerator(np.array([b0, b1, b2]), v, rhs, forward)
        rhs[0 if forward else -1] += state[0] * first
        if len(v) > 1:
            rhs[1 if forward else -2] += state[1] * first
        # dtbtrs's transposed (dot-product) form is ~1.5x faster than its axpy form: forward, A (lower) is
        # solved as the transpose of its upper band; backward, A is upper: the transpose of the lower band
        if forward:
            band[0], band[1], band[2] = a2, a1, 1.0
            y, info = dtbtrs(band, rhs, uplo="U", trans="T", diag="U", overwrite_b=1)
        else:
            band[0], band[1], band[2] = 1.0, a1, a2
            y, info = dtbtrs(band, rhs, uplo="L", trans="T", diag="U", overwrite_b=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"dtbtrs: info {info}")
        if y is not rhs:  # solved in place unless the wrapper had to copy
            rhs[...] = y
        v, rhs = rhs, v
    return v


def default_padlen(sos: np.ndarray) -> int:
    """scipy.signal.sosfiltfilt's default odd-extension length [samples]: three times the filter's taps
    (``2·sections + 1``, one fewer when a section is first-order)."""
    sos = np.asarray(sos)
    first_order = min(int(np.sum(sos[:, 2] == 0)), int(np.sum(sos[:, 5] == 0)))
    return 3 * (2 * len(sos) + 1 - first_order)


def filtfilt_sos(sos: np.ndarray, x: np.ndarray, padlen: int) -> np.ndarray:
    """Zero-phase filtering of ``x`` along axis 0 by the cascade ``sos``, forward then backward, as
    scipy.signal.sosfiltfilt(padtype="odd"): odd extension by ``padlen`` samples at each end, and each
    pass started from the steady state of its first sample (:func:`_sos_initial_state`).  Same shape as ``x``."""
    x = np.asarray(x, dtype=float)
    sos = np.asarray(sos, dtype=float)
    n = x.shape[0]
    if padlen < 0 or n <= padlen:
        raise ValueError(f"{n} samples along axis 0, expected more than padlen = {padlen}")
    flat = x.reshape(n, -1)
    ext = np.empty((n + 2 * padlen, flat.shape[1]), order="F")
    ext[padlen : padlen + n] = flat
    if padlen:
        ext[:padlen] = 2 * flat[0] - flat[padlen:0:-1]
        ext[padlen + n :] = 2 * flat[-1] - flat[-2 : -(padlen + 2) : -1]
    zi = _sos_initial_state(sos)
    spare, band = np.empty_like(ext), np.empty((3, len(ext)), order="F")
    y = _pass(sos, zi, ext, spare, band, forward=True)
    y = _pass(sos, zi, y, spare if y is ext else ext, band, forward=False)
    return np.ascontiguousarray(y[padlen : padlen + n]).reshape(x.shape)


#: Windows up to this many samples are convolved directly, longer ones through the FFT (faster there).
DIRECT_WINDOW = 31


def savgol_matrix(window: int, polyorder: int, deriv: int, delta: float) -> np.ndarray:
    """Savitzky–Golay weights ``(window, window)``: row ``i`` gives the ``deriv``-th derivative [per
    ``delta``^deriv] at sample ``i`` of the least-squares polynomial of ``polyorder`` through a window."""
    half = window // 2
    u = (np.arange(window) - half) / max(half, 1)  # centred and scaled: a well-conditioned Vandermonde
    fit = np.linalg.pinv(np.vander(u, polyorder + 1, increasing=True))  # (polyorder+1) × window
    powers = np.arange(polyorder + 1)
    falling = np.ones(polyorder + 1)
    for k in range(deriv):
        falling *= powers - k
    evaluate = np.where(powers >= deriv, falling * u[:, None] ** np.maximum(powers - deriv, 0), 0.0)
    return evaluate @ fit / (max(half, 1) * delta) ** deriv


def savgol(x: np.ndarray, window: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """Savitzky–Golay filter of ``x`` along axis 0 (odd ``window`` [samples], ``polyorder``, ``deriv``-th
    derivative with sample step ``delta``) with scipy.signal.savgol_filter's ``mode="interp"`` edges: the
    first and last ``window // 2`` samples from the polynomial fitted over the first and last window."""
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if window % 2 != 1 or window < 1 or not 0 <= polyorder < window or not 0 <= deriv:
        raise ValueError(f"window {window}, polyorder {polyorder}, deriv {deriv}: expected an odd window > polyorder")
    if n < window:
        raise ValueError(f"{n} samples along axis 0, expected at least the window of {window}")
    half = window // 2
    weights = savgol_matrix(window, polyorder, deriv, delta)
    flat = np.asfortranarray(x.reshape(n, -1))
    out = np.empty(flat.shape)
    centre = weights[half][::-1]  # correlation with the centre row = convolution with it reversed
    if window <= DIRECT_WINDOW:
        for j in range(flat.shape[1]):
            out[half : n - half, j] = np.convolve(flat[:, j], centre, mode="valid")
    else:
        size = 1 << int(np.ceil(np.log2(n + window - 1)))
        spectrum = np.fft.rfft(flat, size, axis=0) * np.fft.rfft(centre, size)[:, None]
        out[half : n - half] = np.fft.irfft(spectrum, size, axis=0)[2 * half : n]
    out[:half] = weights[:half] @ flat[:window]
    out[n - half :] = weights[half + 1 :] @ flat[n - window :]
    return out.reshape(x.shape)
