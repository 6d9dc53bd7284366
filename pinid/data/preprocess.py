"""Preprocessing: from a raw recording to q, dq, ddq, tau ready for identification.

:func:`prepare` does, in this order:

0. **Unwrapping.**  Joints named in ``unwrap`` (angles without limits: continuous joints, and revolute
   joints whose URDF gives no limits; :func:`~pinid.problem.recordings.load_datasets` passes them)
   are unwrapped first (``numpy.unwrap``): a logger that wraps them to [−π, π) makes a 2π jump that
   the filter and the derivatives would otherwise turn into a huge spike.  The joints changed are
   recorded in ``meta["preprocess"]["unwrapped"]``.
1. **Uniform grid.**  If the time stamps jitter — any step differs from the median step by more than
   1 % — every signal is resampled onto a uniform grid at the median rate (cubic spline through the
   samples; gaps longer than 5 median steps are reported).  ``rate=`` resamples to another rate (after
   a zero-phase anti-alias low-pass at 0.4 × the new rate when that is lower).
2. **Zero-phase low-pass.**  A Butterworth filter of ``order`` (default 4) and ``cutoff`` [Hz], run
   forward and backward (:func:`~pinid.data.filters.filtfilt_sos`: scipy's ``sosfiltfilt`` without
   importing scipy.signal; no phase lag, squared magnitude: −6 dB at the cut-off), applied to the
   positions, the measured velocities and accelerations if used, and the torques alike, so that
   torques and motion stay aligned.  Default cut-off: ``min(10 Hz, fs/10)`` (10 Hz is seed 000's
   choice for leg motion; ``fs/10`` = 0.2 × Nyquist keeps slow recordings sensible).  A cut-off at or above 0.8 × Nyquist is refused.
3. **Derivatives.**  ``differentiation="savgol"`` (default): Savitzky–Golay, polynomial order 5, window
   ``2M+1`` samples with ``M = max(4, round(0.3·fs/cutoff))`` (its own −3 dB point then sits at about
   2.8 × the Butterworth cut-off, so it differentiates without filtering the band again;
   :func:`~pinid.data.filters.savgol`, scipy's ``savgol_filter(mode="interp")``); ``"central"``:
   second-order central differences (``numpy.gradient``) for dq and the 3-point second difference for ddq.
   Measured velocities (``dq`` columns) are used, filtered, when present and ``use_measured_velocity``
   is true; then ddq is the derivative of the filtered velocity.  Measured accelerations likewise.
4. **Trimming.**  ``trim`` seconds are dropped at each end, where the filter and the derivative windows
   see the edge: default ``ln(1000) / (2π·cutoff·sin(π/(2·order))) + (M+1)/fs`` — the time the slowest
   pole of the Butterworth filter needs to decay to 1/1000, plus the derivative window (0.29 s + 0.03 s
   at 10 Hz, order 4).
5. **Decimation.**  Every ``decimate``-th sample is kept (after filtering, so no aliasing).  Default:
   down to no less than ``max(1 kHz, 20 × cutoff)`` — a 5 kHz recording becomes 1 kHz, 1 kHz and
   slower stay as they are.  ``decimate=1`` keeps every sample.

Presets (``preset=``) fill in the options left at their defaults: see :data:`PRESETS`.  The recording as
given is kept in ``meta["recorded"]``: torque errors are measured against it
(:func:`pinid.problem.problem.recorded_torque`), not against the low-passed copy.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING

import numpy as np

from pinid.checks import as_floats, count, number
from pinid.data.dataset import ACC, GYRO, PLATE, QUAT, WRENCH, Dataset
from pinid.data.filters import butter_sos, default_padlen, filtfilt_sos, savgol
from pinid.errors import DataError, SpecError
from pinid.data.formats import warn
from pinid.data.dataset import as_dataset
from pinid.checks import array_like

if TYPE_CHECKING:
    from pinid.data.contacts import FloatingSamples

#: Named recipes, after the paper they reproduce.  ``zha2019``: Zha et al. 2019 — 1 kHz sampling, zero-phase 10 Hz low-pass (the paper
#: gives no order: 4 here; it differentiates by forward differences, which lag half a sample: central
#: differences here).  ``shi2024``: Shi et al. 2024 — Butterworth low-pass run forward and reverse (the
#: paper gives neither order nor cut-off: order 4 and 5 Hz here, ten times its highest trajectory
#: harmonic of 0.4 Hz and above the torque's own harmonics).
PRESETS: dict[str, dict] = {
    "zha2019": {
        "cutoff": 10.0,
        "order": 4,
        "differentiation": "central",
        "rate": 1000.0,
        "description": "Zha et al. 2019 (seed 000): 1 kHz, zero-phase 10 Hz Butterworth low-pass",
    },
    "shi2024": {
        "cutoff": 5.0,
        "order": 4,
        "differentiation": "central",
        "description": "Shi et al. 2024 (seed 001): Butterworth low-pass, forward and reverse (5 Hz, order 4)",
    },
}
#: Old preset names (the seed papers' numbers), accepted with a DeprecationWarning for one release.
DEPRECATED_PRESETS: dict[str, str] = {"seed000": "zha2019", "seed001": "shi2024"}

DIFFERENTIATION = ("savgol", "central")
JITTER_TOLERANCE = 0.01  # relative step deviation that triggers resampling
_DEFAULTS = {"cutoff": None, "order": 4, "differentiation": "savgol", "trim": None, "decimate": None, "rate": None}


def default_cutoff(fs: float) -> float:
    """Default low-pass cut-off [Hz] for a sample rate ``fs`` [Hz]: ``min(10, fs/10)``."""
    fs = number(fs, "fs", low=0, low_open=True)
    return float(min(10.0, fs / 10.0))


SAVGOL_POLYORDER = 5


def savgol_half_window(fs: float, cutoff: float) -> int:
    """Half-width ``M`` of the Savitzky–Golay window (length ``2M+1``) for rate ``fs`` and cut-off [Hz]."""
    fs = number(fs, "fs", low=0, low_open=True)
    cutoff = number(cutoff, "cutoff", low=0, low_open=True)
    return int(max(4, round(0.3 * fs / cutoff)))


def default_trim(fs: float, cutoff: float, order: int) -> float:
    """Default time [s] trimmed at each end: filter settling to 1/1000 plus the derivative window."""
    fs = number(fs, "fs", low=0, low_open=True)
    cutoff = number(cutoff, "cutoff", low=0, low_open=True)
    order = count(order, "order", low=1)
    settle = np.log(1000.0) / (2 * np.pi * cutoff * np.sin(np.pi / (2 * order)))
    return float(settle + (savgol_half_window(fs, cutoff) + 1) / fs)


def lowpass(x: np.ndarray, fs: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` (samples along axis 0) [same unit as x], padded as
    scipy.signal.sosfiltfilt by default (:func:`~pinid.data.filters.default_padlen`)."""
    x = as_floats(array_like(x, "x"), "x")
    fs = number(fs, "fs", low=0, low_open=True)
    cutoff = number(cutoff, "cutoff", low=0, low_open=True)
    if cutoff >= fs / 2:
        raise SpecError(f"cutoff={cutoff:g} Hz, expected below the Nyquist frequency fs/2 = {fs / 2:g} Hz")
    sos = butter_sos(count(order, "order", low=1), cutoff, fs)
    pad = default_padlen(sos)
    if x.ndim == 0 or x.shape[0] <= pad:
        raise DataError(f"x: {0 if x.ndim == 0 else x.shape[0]} samples, expected more than {pad} to filter")
    return filtfilt_sos(sos, x, pad)


def uniform_grid(ds: Dataset, rate: float | None = None) -> tuple[Dataset, dict]:
    """``ds`` on a uniform time grid (resampled when jittered or when ``rate`` is given); and a report."""
    ds = as_dataset(ds)
    t = ds.t
    dt = np.diff(t)
    step = float(np.median(dt))
    jitter = float(np.max(np.abs(dt - step)) / step)
    gaps = np.flatnonzero(dt > 5 * step)
    report = {"median_step": step, "jitter": jitter, "resampled": False}
    if gaps.size:
        k = int(gaps[0])
        warn(
            ds,
            f"{ds.source}: {gaps.size} gap(s) in the time stamps, the first of {dt[k]:.4g} s at t = {t[k]:.6g} s "
            f"(median step {step:.4g} s); interpolated across",
        )
    if jitter <= JITTER_TOLERANCE and (rate is None or abs(rate * step - 1.0) <= 1e-9):
        return ds, report
    new_step = 1.0 / rate if rate else step
    n = int(np.floor((t[-1] - t[0]) / new_step + 1e-9)) + 1
    tn = t[0] + np.arange(n) * new_step
    tn[-1] = min(tn[-1], t[-1])

    # deliberately deferred: scipy.interpolate is slow to import; only resampling needs it
    from scipy.interpolate import CubicSpline

    anti_alias = None
    if rate and rate < 0.95 / step:
        # downsampling: a zero-phase anti-alias low-pass at 0.4 × the new rate first
        anti_alias = butter_sos(8, 0.4 * rate, 1.0 / step)

    def interp(a):
        if a is None:
            return None
        if anti_alias is not None:
            a = filtfilt_sos(anti_alias, a, default_padlen(anti_alias))
        return CubicSpline(t, a, axis=0)(tn)

    out = Dataset(
        t=tn,
        q=interp(ds.q),
        joints=list(ds.joints),
        dq=interp(ds.dq),
        ddq=interp(ds.ddq),
        tau=interp(ds.tau),
        source=ds.source,
        meta=dict(ds.meta),
    )
    report.update(resampled=True, rate=1.0 / new_step)
    return out, report


@dataclass(frozen=True)
class Preprocessing:
    """The options of :func:`prepare`, one object (the ``preprocess`` dict of :func:`pinid.identify`, a
    manifest's ``[preprocess]`` table and the CLI options in Python form, with the same keys).

    ``preset`` ("zha2019", "shi2024"; the old "seed000", "seed001" are deprecated) fills the options left at
    their defaults; ``cutoff`` [Hz] (default ``min(10, fs/10)``), ``order`` of the Butterworth filter run forward
    and backward; ``differentiation`` "savgol" or "central"; ``use_measured_velocity``,
    ``use_measured_acceleration`` (default None: true for a Dataset, false for a floating recording, whose base
    and wrench signals have no measured derivatives); ``trim`` [s] dropped at each end (default the filter's
    settling time plus the derivative window); ``decimate`` keep every n-th sample (default: down to
    ``max(1 kHz, 20·cutoff)``); ``rate`` [Hz] resample to this uniform rate first (by default only jittered
    recordings are resampled, at their median rate); ``unwrap``: joints whose angles are unwrapped first (2π
    jumps removed; angles without limits).  The values are checked by :func:`prepare`.
    """

    preset: str | None = None
    cutoff: float | None = None
    order: int = 4
    differentiation: str = "savgol"
    use_measured_velocity: bool | None = None
    use_measured_acceleration: bool | None = None
    trim: float | None = None
    decimate: int | None = None
    rate: float | None = None
    unwrap: tuple[str, ...] = ()

    @classmethod
    def from_dict(cls, options: Mapping) -> "Preprocessing":
        """The options of a ``preprocess`` dict (its keys: the field names); SpecError naming an unknown key."""
        if isinstance(options, Preprocessing):
            return options
        if not isinstance(options, Mapping):
            raise SpecError(
                f"preprocess: got {type(options).__name__}, expected a dict of preprocessing options or a Preprocessing"
            )
        known = [f.name for f in fields(cls)]
        unknown = [k for k in options if k not in known]
        if unknown:
            raise SpecError(f"preprocess: unknown option(s) {unknown}, expected some of {', '.join(known)}")
        out = dict(options)
        if "unwrap" in out and out["unwrap"] is not None:
            u = out["unwrap"]
            if isinstance(u, str) or not isinstance(u, Iterable):
                raise SpecError(f"unwrap {u!r}, expected a list of joint names")
            out["unwrap"] = tuple(u)
        return cls(**out)

    def to_dict(self) -> dict:
        """The options set (not None), by name: the ``preprocess`` dict form."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}

    @classmethod
    def normalize(cls, value: "Preprocessing | Mapping | bool | None", what: str = "preprocess") -> dict | bool | None:
        """The one form the runners carry the preprocessing in (:class:`~pinid.identification.study.Study`,
        :func:`~pinid.problem.recordings.prepare_dataset`): None, True and False as they are, a mapping as a dict
        (its keys checked where it is used), a :class:`Preprocessing` as the dict of the options it sets (those
        other than their defaults: ``Preprocessing(cutoff=8.0)`` → ``{"cutoff": 8.0}``, the numbers of the dict
        form).  SpecError (one line, naming ``what``) for anything else."""
        if value is None or isinstance(value, bool):
            return value
        if isinstance(value, Preprocessing):
            return {f.name: getattr(value, f.name) for f in fields(cls) if getattr(value, f.name) != f.default}
        if isinstance(value, Mapping):
            return dict(value)
        raise SpecError(
            f"{what}: got {type(value).__name__}, expected a Preprocessing, a dict of its options, True, False or None"
        )


def prepare(ds: Dataset, options: Preprocessing | Mapping | bool | None = None) -> Dataset | FloatingSamples:
    """Filter, differentiate, trim and decimate a recording; return a dataset with q, dq, ddq, tau filled.

    ``options``: a :class:`Preprocessing` or its dict form (``{"cutoff": 20.0, "order": 2}``, the keys of a
    manifest's ``[preprocess]`` table); None or True: the defaults; False: the recording as it is (a fixed-base
    one returned unchanged).  The options used are recorded in ``meta["preprocess"]``.  Raises DataError when
    there is no torque, too few samples, or a cut-off the sample rate cannot carry.

    A floating recording (a Dataset whose ``floating`` channels are set, :class:`~pinid.data.dataset.FloatingChannels`)
    gives its :class:`~pinid.data.contacts.FloatingSamples`: the base motion, IMU and wrenches filtered and
    differentiated with the joints, with the same options, the wrenches zeroed out of contact (phase 0; where a
    foot switch chatters, :data:`CONTACT_MARGIN`, the rows its wrench enters are left out), the base state in
    Pinocchio's free-flyer convention.  Its joints' measured ``dq_``/``ddq_`` columns are not used unless
    ``use_measured_velocity``/``use_measured_acceleration`` say so (its base and wrench signals have none);
    with False it needs them, takes the base and wrench derivatives from central differences and drops the two
    samples at each end.
    """
    if not isinstance(ds, Dataset):
        raise DataError(f"prepare: got {type(ds).__name__}, expected a pinid Dataset (pinid.data.read_recording)")
    if not isinstance(options, bool):
        options = Preprocessing() if options is None else Preprocessing.from_dict(options)
    if ds.floating is not None:  # one prepare whatever the base
        return _prepare_floating(ds, options)
    if options is False:
        return ds
    if options is True:
        options = Preprocessing()
    preset, cutoff, order, differentiation = options.preset, options.cutoff, options.order, options.differentiation
    use_measured_velocity = options.use_measured_velocity
    use_measured_acceleration = options.use_measured_acceleration
    trim, decimate, rate, unwrap = options.trim, options.decimate, options.rate, options.unwrap
    use_measured_velocity = True if use_measured_velocity is None else use_measured_velocity
    use_measured_acceleration = True if use_measured_acceleration is None else use_measured_acceleration
    cutoff, trim, rate = (
        None if v is None else number(v, name) for name, v in (("cutoff", cutoff), ("trim", trim), ("rate", rate))
    )
    given = {
        "cutoff": cutoff,
        "order": order,
        "differentiation": differentiation,
        "trim": trim,
        "decimate": decimate,
        "rate": rate,
    }
    if preset in DEPRECATED_PRESETS:
        warnings.warn(
            f"preprocessing preset {preset!r} is deprecated, use {DEPRECATED_PRESETS[preset]!r}",
            DeprecationWarning,
            stacklevel=2,
        )
        preset = DEPRECATED_PRESETS[preset]
    if preset is not None:
        if preset not in PRESETS:
            raise SpecError(f"preprocessing preset {preset!r} is unknown, expected one of {', '.join(PRESETS)}")
        for k, v in PRESETS[preset].items():
            if k in given and given[k] == _DEFAULTS[k]:
                given[k] = v
    cutoff, order, differentiation = given["cutoff"], given["order"], given["differentiation"]
    trim, decimate, rate = given["trim"], given["decimate"], given["rate"]
    src = ds.source
    if differentiation not in DIFFERENTIATION:
        raise SpecError(f"differentiation {differentiation!r}, expected one of {', '.join(DIFFERENTIATION)}")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 1 <= order <= 10:
        raise SpecError(f"filter order {order!r}, expected an integer from 1 to 10")
    if ds.tau is None:
        raise DataError(f"{src}: no torque (tau) columns, expected measured joint torques to identify from")
    if ds.n < 10:
        raise DataError(f"{src}: {ds.n} samples, expected at least 10 to filter and differentiate")
    if rate is not None and (not np.isfinite(rate) or rate <= 0):
        raise SpecError(f"resampling rate {rate!r}, expected a rate > 0 [Hz]")
    recorded = ds.meta.get("recorded", ds)  # the recording as read: the yardstick of torque errors
    ds, unwrapped = _unwrap(ds, unwrap)
    ds, grid = uniform_grid(ds, rate)
    fs = float(f"{1.0 / float(np.median(np.diff(ds.t))):.9g}")  # 1000 Hz, not 999.9999999999991 Hz
    nyquist = fs / 2
    if cutoff is None:
        if fs < 10.0:
            raise DataError(
                f"{src}: sample rate {fs:.3g} Hz is too low for the default low-pass "
                "(needs at least 10 Hz); expected a recording sampled at 10 Hz or faster"
                + (
                    f"; time stamps in milliseconds? ({1e3 * fs:.4g} Hz then) a mapping spec converts them: "
                    'time = { column = "t", scale = "ms" } (docs/data.md)'
                    if 1e3 * fs >= 10.0
                    else ""
                )
            )
        cutoff = default_cutoff(fs)
    elif not np.isfinite(cutoff) or cutoff <= 0:
        raise SpecError(f"cut-off {cutoff!r}, expected a frequency > 0 [Hz]")
    if cutoff >= 0.8 * nyquist:
        raise DataError(
            f"{src}: sample rate {fs:.4g} Hz is too low for a {cutoff:g} Hz low-pass: the cut-off must be "
            f"below 0.8 × Nyquist = {0.8 * nyquist:.4g} Hz; expected a sample rate above {2.5 * cutoff:.4g} Hz "
            "or a lower cut-off"
        )
    sos = butter_sos(order, cutoff, fs)
    padlen = 3 * (2 * len(sos) + 1)
    M = savgol_half_window(fs, cutoff)
    if trim is None:
        trim = default_trim(fs, cutoff, order)
    elif not np.isfinite(trim) or trim < 0:
        raise SpecError(f"trim {trim!r}, expected a duration >= 0 [s]")
    n_trim = int(np.ceil(trim * fs - 1e-9))
    if ds.n <= max(padlen, 2 * n_trim + 10):
        raise DataError(
            f"{src}: {ds.n} samples ({ds.duration:.3g} s) are too few for a {cutoff:g} Hz order-{order} "
            f"low-pass trimmed by {trim:.3g} s at each end; expected more than {max(padlen, 2 * n_trim + 10)} samples"
        )

    measured_v = ds.dq is not None and use_measured_velocity
    measured_a = ds.ddq is not None and use_measured_acceleration
    if differentiation == "savgol" and not (measured_v and measured_a) and ds.n < 2 * M + 1:
        raise DataError(
            f"{src}: {ds.n} samples ({ds.duration:.3g} s) are fewer than the {2 * M + 1}-sample Savitzky–Golay "
            f"window of a {cutoff:g} Hz cut-off; expected a longer recording, a higher cut-off or "
            "differentiation='central'"
        )

    # pad (odd extension) over the filter's settling time, so that its start-up transient dies out
    # before it reaches the data (scipy's default of 3·(2·sections+1) samples is too short at high rates)
    pad = int(min(ds.n - 1, max(padlen, np.ceil(default_trim(fs, cutoff, order) * fs))))

    def filt(a):
        return filtfilt_sos(sos, a, pad)

    h = 1.0 / fs
    q = filt(ds.q)
    tau = filt(ds.tau)
    polyorder = SAVGOL_POLYORDER

    def d1(a):
        if differentiation == "savgol":
            return savgol(a, 2 * M + 1, polyorder, deriv=1, delta=h)
        return np.gradient(a, h, axis=0)

    def d2(a):
        if differentiation == "savgol":
            return savgol(a, 2 * M + 1, polyorder, deriv=2, delta=h)
        out = np.empty_like(a)
        out[1:-1] = (a[2:] - 2 * a[1:-1] + a[:-2]) / (h * h)
        out[0], out[-1] = out[1], out[-2]
        return out

    dq = filt(ds.dq) if measured_v else d1(q)
    if measured_a:
        ddq = filt(ds.ddq)
    elif measured_v:
        ddq = d1(dq)
    else:
        ddq = d2(q)
    if decimate is None:
        decimate = max(1, int(np.floor(fs / max(1000.0, 20.0 * cutoff) + 1e-9)))
    elif isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise SpecError(f"decimate {decimate!r}, expected an integer >= 1")
    elif cutoff >= 0.8 * (fs / decimate) / 2:
        raise DataError(
            f"{src}: decimating {fs:.4g} Hz by {decimate} leaves {fs / decimate:.4g} Hz, too low for the "
            f"{cutoff:g} Hz low-pass (needs above {2.5 * cutoff:.4g} Hz); expected a smaller factor"
        )
    keep = slice(n_trim, ds.n - n_trim if n_trim else None, decimate)
    meta = dict(ds.meta)
    meta["recorded"] = recorded
    meta["preprocess"] = {
        "preset": preset,
        "sample_rate": fs,
        "resampled": grid["resampled"],
        "jitter": grid["jitter"],
        "cutoff": float(cutoff),
        "order": int(order),
        "filter": "butterworth, zero-phase (sosfiltfilt)",
        "differentiation": differentiation,
        "savgol_window": 2 * M + 1 if differentiation == "savgol" else None,
        "measured_velocity": bool(measured_v),
        "measured_acceleration": bool(measured_a),
        "trim": float(trim),
        "decimate": int(decimate),
        "output_rate": fs / decimate,
        "unwrapped": unwrapped,
    }
    _warn_content_above_cutoff(ds, q, fs, cutoff)
    return Dataset(
        t=ds.t[keep],
        q=q[keep],
        joints=list(ds.joints),
        dq=dq[keep],
        ddq=ddq[keep],
        tau=tau[keep],
        source=ds.source,
        meta=meta,
    )


def _unwrap(ds: Dataset, joints) -> tuple[Dataset, list[str]]:
    """``ds`` with the positions of ``joints`` unwrapped (2π jumps removed), and the joints that changed."""
    unknown = [j for j in joints if j not in ds.joints]
    if unknown:
        raise SpecError(f"unwrap: joint(s) {unknown} not in {ds.source} (its joints: {', '.join(ds.joints)})")
    cols = [ds.joints.index(j) for j in joints]
    if not cols:
        return ds, []
    q = ds.q.copy()
    q[:, cols] = np.unwrap(q[:, cols], axis=0)
    changed = [ds.joints[c] for c in cols if not np.array_equal(q[:, c], ds.q[:, c])]
    return (replace(ds, q=q) if changed else ds), changed


#: A joint whose recorded range is below this [rad or m] is held still: what a low-pass removes there is noise.
STILL_RANGE = 0.01


def _warn_content_above_cutoff(ds: Dataset, q_filtered: np.ndarray, fs: float, cutoff: float) -> None:
    """Warn when the low-pass removes more than 1 % of the position signal's (detrended) variance of a
    joint that moves (range at least :data:`STILL_RANGE`; on a joint held still that is only noise)."""
    raw = ds.q - ds.q.mean(axis=0)
    removed = ds.q - q_filtered
    var = np.where(np.ptp(ds.q, axis=0) >= STILL_RANGE, raw.var(axis=0), 0.0)
    frac = np.divide(removed.var(axis=0), var, out=np.zeros_like(var), where=var > 0)
    j = int(np.argmax(frac))
    if frac[j] > 0.01:
        warn(
            ds,
            f"{ds.source}: the {cutoff:g} Hz low-pass removes {100 * frac[j]:.2g} % of the position variance of "
            f"joint '{ds.joints[j]}': the motion may be faster than the cut-off (pass a higher cut-off)",
        )


#: A filtered contact phase within this of 0 or 1 is clear.  Where it is not (``CONTACT_MARGIN < phase <
#: 1 − CONTACT_MARGIN``) and the raw phase changes more than once there (a foot switch that chatters), the rows
#: the link's wrench enters are left out; a single clean step is gated at 0.5.  A clean step through the default
#: 10 Hz low-pass is in that band for about 40 ms, and rings to −0.07 / 1.07 outside it.
CONTACT_MARGIN = 0.1


def _prepare_floating(ds: Dataset, preprocess: Preprocessing | bool | None) -> FloatingSamples:
    """A floating recording (``ds.floating``) prepared: joints and base motion filtered and differentiated together,
    wrenches zeroed out of contact, the base state in Pinocchio's free-flyer convention.  ``preprocess`` None or
    True: filter every signal with the defaults, the joints' ``dq_``/``ddq_`` columns unused; options: the same with
    them; False: the recording as it is, which then needs ``dq_`` and ``ddq_`` columns, takes the base and wrench
    derivatives from central differences and drops the two samples at each end, whose differences would be
    one-sided."""
    # deferred: the floating channels' helpers load pinocchio, which a fixed-base preparation does not need
    from pinid.data.contacts import FloatingSamples, matrix_quat, quat_matrix, quat_mul
    from pinid.model.floating import Wrench, as_floating

    rec = ds.floating
    if rec.model is None:
        raise DataError(
            f"{ds.source}: a floating recording without its model; read it with read_recording(path, model=model) "
            "of a floating model"
        )
    model = as_floating(rec.model)
    ds = replace(ds, floating=None).reorder(model.joint_names)
    extra = rec.columns()
    for link, p7 in rec.plates.items():  # force plates as world wrenches before filtering (linear in the signals)
        for c in PLATE:
            extra.pop(f"plate_{link}_{c}")
        moment = np.cross(p7[:, 3:6], p7[:, :3]) + np.column_stack([np.zeros((len(p7), 2)), p7[:, 6]])
        extra.update({f"plate_{link}_{c}": v for c, v in zip(WRENCH, np.hstack([p7[:, :3], moment]).T)})
    # every signal goes through the same filter, differentiation and trimming as the joints
    names = list(extra)
    n, nv = ds.n, model.nv
    q = np.hstack([ds.q, np.column_stack([extra[c] for c in names])]) if names else ds.q
    width = q.shape[1]

    def widen(a):
        return None if a is None else np.hstack([a, np.zeros((n, width - nv))])

    tau = ds.tau if ds.tau is not None else np.zeros((n, nv))
    big = Dataset(ds.t, q, [*ds.joints, *names], dq=widen(ds.dq), ddq=widen(ds.ddq), tau=widen(tau), source=ds.source)
    needs = ds.dq is None or ds.ddq is None
    # "auto" (None) filters every signal here, whatever dq_/ddq_ columns the joints have: the base pose, IMU and
    # wrenches have no given derivatives, and differentiating them unfiltered amplifies their noise
    if preprocess is False:
        if needs:
            raise DataError(f"{ds.source}: no dq_/ddq_ columns and preprocessing off; expected both or preprocessing")
        if n < 5:
            raise DataError(f"{ds.source}: {n} samples; expected at least 5 with preprocessing off")
        sig_dq = np.gradient(q[:, nv:], ds.t, axis=0)
        sig_ddq = np.gradient(sig_dq, ds.t, axis=0)
        keep = slice(2, n - 2)  # the two end samples of each side hold one-sided differences: dropped
        t, jq, jdq, jddq, sig = ds.t[keep], ds.q[keep], ds.dq[keep], ds.ddq[keep], q[keep, nv:]
        jtau = None if ds.tau is None else ds.tau[keep]
        sig_dq, sig_ddq = sig_dq[keep], sig_ddq[keep]
    else:
        opts = {} if preprocess in (None, True) else preprocess.to_dict()
        opts = {"use_measured_velocity": False, "use_measured_acceleration": False, **opts}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            p = prepare(big, opts)
        for w in caught:  # the filter's warnings about the joints, not about the base and wrench signals
            if not any(f"'{c}'" in str(w.message) for c in names):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        t, jq, jdq, jddq = p.t, p.q[:, :nv], p.dq[:, :nv], p.ddq[:, :nv]
        jtau = None if ds.tau is None else p.tau[:, :nv]
        sig, sig_dq, sig_ddq = p.q[:, nv:], p.dq[:, nv:], p.ddq[:, nv:]
    col = {c: i for i, c in enumerate(names)}

    def block(prefix, keys, arr=sig):
        return np.column_stack([arr[:, col[f"{prefix}{k}"]] for k in keys])

    m = len(t)
    if rec.base_pose is not None:
        pos = block("base_", ("x", "y", "z"))
        quat = block("base_", QUAT)
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        conj = quat * np.array([-1, -1, -1, 1.0])
        omega = 2 * quat_mul(conj, block("base_", QUAT, sig_dq))[:, :3]
        domega = 2 * quat_mul(conj, block("base_", QUAT, sig_ddq))[:, :3]
        R = quat_matrix(quat)
        acc = np.einsum("nji,nj->ni", R, block("base_", ("x", "y", "z"), sig_ddq))  # Rᵀ p̈
    else:
        f = rec.imu_frame
        frame = model.ff_model.frames[model.frame_id(f)]
        R_bi, r = frame.placement.rotation, frame.placement.translation
        q_i = block(f"imu_{f}_", QUAT)
        q_i /= np.linalg.norm(q_i, axis=1, keepdims=True)
        R_wb = quat_matrix(q_i) @ R_bi.T
        quat, pos = matrix_quat(R_wb), np.zeros((m, 3))
        omega = block(f"imu_{f}_", GYRO) @ R_bi.T
        domega = block(f"imu_{f}_", GYRO, sig_dq) @ R_bi.T
        s_b = block(f"imu_{f}_", ACC) @ R_bi.T
        g = np.asarray(model.ff_model.gravity.linear)
        a_imu = s_b + np.einsum("nji,j->ni", R_wb, g)
        acc = a_imu - np.cross(domega, r) - np.cross(omega, np.cross(omega, r))
    base_q = np.hstack([pos, quat])
    base_v = np.hstack([np.zeros((m, 3)), omega])
    base_a = np.hstack([acc, domega])
    wrenches = []
    # the filter spreads a phase's step over a few samples: a measured wrench is zeroed below 0.5; where a foot
    # switch chatters (its filtered phase hovers between 0 and 1 for the whole bounce) the rows the wrench enters
    # are left out (``uncertain``); a link without a measured wrench counts as in contact above 0.05 (its rows
    # are left out: conservative)
    phase = {link: sig[:, col[f"contact_{link}"]] for link in rec.contacts}
    contact = {link: p > 0.5 for link, p in phase.items()}
    uncertain = {
        link: _chattering(ds.t, rec.contacts[link], t, np.abs(p - 0.5) < 0.5 - CONTACT_MARGIN)
        for link, p in phase.items()
        if link in rec.wrenches or link in rec.plates
    }
    for link in rec.wrenches:
        w = block(f"wrench_{link}_", WRENCH)
        wrenches.append(Wrench(link, _gate(w, contact.get(link)), "local"))
    for link in rec.plates:
        w = block(f"plate_{link}_", WRENCH)  # world wrench about the origin (converted above)
        wrenches.append(Wrench(link, _gate(w, contact.get(link)), "world"))
    data = Dataset(t, jq, list(model.joint_names), dq=jdq, ddq=jddq, tau=jtau, source=ds.source, meta=dict(ds.meta))
    unsensed = {link: p > 0.05 for link, p in phase.items() if link not in uncertain}
    return FloatingSamples(data, base_q, base_v, base_a, wrenches, unsensed, uncertain)


def _chattering(t_raw: np.ndarray, raw: np.ndarray, t: np.ndarray, band: np.ndarray) -> np.ndarray:
    """(N,) booleans: the samples of ``band`` (the filtered phase neither clearly 0 nor 1, at times ``t`` [s]) in a
    run of it within which the raw phase (``raw`` at ``t_raw``) changes more than once: a chattering switch.  A
    single clean step keeps its samples (gated at 0.5), so a recording whose phases do not chatter is unchanged."""
    changes = np.flatnonzero(np.diff(np.asarray(raw, dtype=int)))
    edges = 0.5 * (t_raw[changes] + t_raw[changes + 1])  # [s], between the samples either side of a change
    d = np.diff(np.r_[0, band.astype(int), 0])
    out = np.zeros(len(band), bool)
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
        lo, hi = t[a - 1] if a else -np.inf, t[b] if b < len(t) else np.inf  # the run and half a sample each side
        if np.count_nonzero((edges > lo) & (edges < hi)) > 1:
            out[a:b] = True
    return out


def _gate(w: np.ndarray, contact: np.ndarray | None) -> np.ndarray:
    """The wrench with zeros out of contact (phase 0)."""
    off = np.zeros(len(w), bool) if contact is None else ~contact
    return np.where(off[:, None], 0.0, w)
