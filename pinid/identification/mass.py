"""The total mass and the whole-body centre of mass an identification determines, with σ (issue 46).

On a floating base the 6 base rows always determine the total mass Σ mᵢ (and the first moments, so the centre of
mass); on a fixed base only a vertical prismatic joint's force carries it.  Which combination of the base parameters
is Σ mᵢ is read from the base map (:func:`total_mass_combination`), not from a name: the QR may lead the mass group
with any body's mass.  σ: the Newey–West covariance of the base parameters (:mod:`pinid.problem.covariance`),
linearised for the centre of mass.
"""

from __future__ import annotations

import contextlib

import numpy as np

from pinid.errors import DataError, SpecError
from pinid.identification.floating_checks import first_moments_map, total_mass_combination


#: The largest tall regressor (bytes) :func:`mass_and_com` builds whole for its covariances (one pass over the
#: recordings instead of two per method); above it the blocks are streamed as everywhere else (issue 35's memory).
WHOLE_REGRESSOR_BYTES = 128 * 2**20


@contextlib.contextmanager
def whole_regressor(problem, limit: int = WHOLE_REGRESSOR_BYTES):
    """Within the block, ``problem``'s tall regressor built once and held (when it is built block by block and
    takes at most ``limit`` bytes), so that several passes over it cost one; let go at the end."""
    built = bool(getattr(problem, "blocked", False)) and problem.rows * problem.nb * 8 <= limit
    if built:
        problem.__dict__["_W"] = problem.regressor_rows.build()
    try:
        yield problem
    finally:
        if built:
            problem.__dict__.pop("_W", None)


def mass_and_com(ident, model, problem, q: np.ndarray) -> dict | None:
    """Each method's total mass and whole-body centre of mass (base frame, posture ``q``) with σ, into its
    ``info["total_mass"]`` (``{"value", "std"}`` [kg]) and ``info["com"]``, ``info["com_std"]`` [m]; the URDF's into
    ``ident.data["total_mass_urdf"]`` and ``["com_urdf"]``.  The mass is ``m = cᵀ·x`` (c:
    :func:`total_mass_combination`), the centre of mass ``L·x / m`` (L: :func:`first_moments_map`); their σ by
    linearising at the estimate, with the Newey–West covariance of the base parameters
    (:func:`pinid.problem.statistics.base_covariance`) scaled to each method's own σ (for a single base parameter,
    such as ``base.mR``, exactly its σ).  Returns ``{method: {"mass", "mass_std", "com", "com_std"}}``; None when the
    rows used do not determine the mass.  The tall regressor is held whole meanwhile when small enough
    (:func:`whole_regressor`)."""
    c = total_mass_combination(problem.base)
    if c is None or not ident.results:
        return None
    q = np.asarray(q, dtype=float)
    L = first_moments_map(model, problem.terms, problem.base, q)
    nominal = np.asarray(ident.base["nominal"], dtype=float)
    ident.data["total_mass_urdf"] = float(c @ nominal)
    ident.data["com_urdf"] = (L @ nominal / (c @ nominal)).tolist()
    out = {}
    with whole_regressor(problem):
        for method, r in ident.results.items():
            out[method] = _mass_and_com_of(r, c, L, problem)
    return out


def _mass_and_com_of(r, c: np.ndarray, L: np.ndarray, problem) -> dict:
    """:func:`mass_and_com` of one result ``r``: into its ``info``, and returned."""
    from pinid.problem.statistics import base_covariance

    x, std = np.asarray(r.base, dtype=float), np.asarray(r.std, dtype=float)
    m = float(c @ x)
    com = L @ x / m if m > 0 else np.full(3, np.nan)
    m_std, com_std = np.nan, np.full(3, np.nan)
    if np.any(np.isfinite(std)):
        C = base_covariance(problem, x)  # at each method's own estimate: its residual's sandwich
        d = np.sqrt(np.clip(np.diag(C), 0.0, None))
        k = np.where(d > 0, std / np.where(d > 0, d, 1.0), np.nan)  # each method's σ, the sandwich's correlation
        Cm = C * np.outer(k, k)
        J = np.vstack([c, (L / m - np.outer(L @ x, c) / m**2) if m > 0 else np.zeros((3, len(x)))])
        used = np.any(J != 0, axis=0)
        sub = Cm[np.ix_(used, used)]
        if np.all(np.isfinite(sub)):
            var = np.diag(J[:, used] @ sub @ J[:, used].T)
            m_std = float(np.sqrt(max(var[0], 0.0)))
            if m > 0:
                com_std = np.sqrt(np.clip(var[1:], 0.0, None))
    r.info["total_mass"] = {"value": m, "std": m_std}
    r.info["com"], r.info["com_std"] = com.tolist(), com_std.tolist()
    return {"mass": m, "mass_std": m_std, "com": com, "com_std": com_std}


def fixed_total_mass(s, results: dict, summary: dict, nominal) -> None:
    """A fixed base's total mass with σ where its torque rows determine it (a vertical prismatic first joint carries
    Σ mᵢ; revolute joints never do): each method's ``info["total_mass"]``, the URDF's ``summary["total_mass_urdf"]``
    (issue 46); nothing otherwise."""
    from pinid.problem.statistics import base_covariance

    c = total_mass_combination(s.base)
    if c is None or nominal is None or len(nominal) != len(c):
        return
    summary["total_mass_urdf"] = float(c @ np.asarray(nominal, dtype=float))
    for r in results.values():
        x, std = np.asarray(r.base, dtype=float), np.asarray(r.std, dtype=float)
        if len(x) != len(c):
            continue
        used = np.flatnonzero(c)
        if len(used) == 1:
            sigma = float(abs(c[used[0]]) * std[used[0]])
        else:  # the sandwich's correlations, each method's own σ
            try:
                C = base_covariance(s.problem, x)
                d = np.sqrt(np.clip(np.diag(C), 0.0, None))
                k = np.where(d > 0, std / np.where(d > 0, d, 1.0), np.nan)
                sub = (C * np.outer(k, k))[np.ix_(used, used)]
                sigma = float(np.sqrt(max(c[used] @ sub @ c[used], 0.0)))
            except (SpecError, DataError, ValueError, np.linalg.LinAlgError):
                sigma = float("nan")
        r.info["total_mass"] = {"value": float(c @ x), "std": sigma}
