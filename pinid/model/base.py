"""Base parameters: the identifiable linear combinations of the standard parameters.

Computed numerically (Gautier's method): the regressor of random states inside the limits is
column-normalised and factorised by QR with column pivoting; its rank gives the number of base
parameters, the pivots the independent columns, and least squares the map of the dependent columns
onto them.  Then ``W @ theta == W[:, independent] @ (P @ theta)`` for every state, with
``base = P @ theta``.  A fixed seed makes the result deterministic for a given model.

A base parameter is named after its independent column, with the suffix ``R`` ("regrouped") when other
standard parameters are folded into it (``hip.IyyR = hip.Iyy + 0.1764·knee.m + …``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from pinid.checks import as_floats, count, number
from pinid.errors import DataError, ModelError, SpecError
from pinid.model.floating import ROW_SETS, FloatingRobotModel, random_floating_states, row_mask
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import STRIBECK_TERMS, as_terms
from pinid.model.regressor import parameter_names, regressor
from pinid.model.terms import TermSelection
from pinid.io import read_json, write_json


@dataclass
class BaseParameters:
    """The base-parameter set of a model.

    ``independent``: indices of the standard columns kept (ascending).  ``P``: ``(nb, p)`` map from
    standard to base parameters.  ``names`` and ``expressions``: one per base parameter.
    """

    standard_names: list[str]
    independent: np.ndarray
    P: np.ndarray
    names: list[str] = field(default_factory=list)
    fit_joints: list[str] | None = None  # computed from these joints' torque rows only (None: every joint's)

    @property
    def count(self) -> int:
        """Number of base parameters."""
        return len(self.independent)

    def marks(self) -> dict[str, str]:
        """``{standard name: mark}``: whether the data determine each standard parameter
        (:func:`identifiability`): ``"identified"``, ``"partly"`` or ``"not identified"``."""
        return dict(zip(self.standard_names, identifiability(self.P)))

    @property
    def unidentifiable(self) -> list[str]:
        """Standard parameters that appear in no base parameter (they do not affect the torque)."""
        return [n for i, n in enumerate(self.standard_names) if not np.any(self.P[:, i])]

    def from_standard(self, theta: np.ndarray) -> np.ndarray:
        """Base parameters of the standard parameters ``theta``."""
        theta = as_floats(theta, "theta")
        if theta.ndim not in (1, 2) or theta.shape[0] != len(self.standard_names):
            raise DataError(f"theta: shape {theta.shape}, expected ({len(self.standard_names)},) standard parameters")
        return self.P @ theta

    def shown(self, theta: np.ndarray) -> np.ndarray:
        """The base parameters of ``theta`` (1-D) as shown to a user (the nominal ones of the URDF): a
        combination whose terms cancel to round-off (below 1e-12 of ``Σ|P_ij·θ_j|``, e.g. 2.8e-17) is 0."""
        base = self.from_standard(theta)
        scale = np.abs(self.P) @ np.abs(np.asarray(theta, dtype=float))
        return np.where(np.abs(base) < 1e-12 * scale, 0.0, base) + 0.0

    def columns(self, W: np.ndarray) -> np.ndarray:
        """The base regressor: the independent columns of a stacked standard regressor ``W``."""
        W = as_floats(W, "W")
        if W.ndim != 2 or W.shape[1] != len(self.standard_names):
            raise DataError(
                f"W: shape {W.shape}, expected (rows, {len(self.standard_names)}) standard regressor columns"
            )
        return W[:, self.independent]

    def expressions(self, digits: int = 6) -> list[str]:
        """Each base parameter as a readable combination of standard parameter names."""
        out = []
        for row in self.P:
            parts = []
            for i in np.flatnonzero(row):
                c = row[i]
                mag = f"{abs(c):.{digits}g}"
                term = self.standard_names[i] if mag == "1" else f"{mag}·{self.standard_names[i]}"
                parts.append(("- " if c < 0 else "+ ") + term)
            text = " ".join(parts)
            out.append(text[2:] if text.startswith("+ ") else "-" + text[2:])
        return out

    def to_dict(self) -> dict:
        """Plain-dict form (JSON-serialisable)."""
        return {
            "names": self.names,
            "expressions": self.expressions(),
            "independent": [self.standard_names[i] for i in self.independent],
            "standard_names": self.standard_names,
            "P": self.P.tolist(),
            **({} if self.fit_joints is None else {"fit_joints": list(self.fit_joints)}),
        }

    def save(self, path) -> None:
        """Write as JSON."""
        write_json(path, self.to_dict())

    @classmethod
    def from_dict(cls, d: dict, *, source: str = "base parameters") -> "BaseParameters":
        """Inverse of :meth:`to_dict`; DataError naming ``source`` and the field if ``d`` is not of that form."""
        if not isinstance(d, Mapping):
            raise DataError(f"{source}: got {type(d).__name__}, expected an object with standard_names, independent, P")
        missing = [k for k in ("standard_names", "independent", "P", "names") if k not in d]
        if missing:
            raise DataError(f"{source}: no {', '.join(missing)}, expected the fields BaseParameters.to_dict writes")
        names = d["standard_names"]
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise DataError(f"{source}: standard_names is not a list of parameter names")
        if not isinstance(d["independent"], list) or any(n not in names for n in d["independent"]):
            raise DataError(f"{source}: independent must list names that are in standard_names")
        if not isinstance(d["names"], list) or len(d["names"]) != len(d["independent"]):
            raise DataError(f"{source}: names must list one name per independent parameter")
        try:
            P = np.array(d["P"], dtype=float)
        except (TypeError, ValueError):
            raise DataError(f"{source}: P is not a matrix of numbers") from None
        if P.shape != (len(d["independent"]), len(names)) or not np.all(np.isfinite(P)):
            raise DataError(
                f"{source}: P of shape {P.shape}, expected finite numbers of shape "
                f"({len(d['independent'])}, {len(names)}) (base × standard)"
            )
        joints = d.get("fit_joints")
        if joints is not None and (not isinstance(joints, list) or not all(isinstance(j, str) for j in joints)):
            raise DataError(f"{source}: fit_joints is not a list of joint names")
        return cls(
            names,
            np.array([names.index(n) for n in d["independent"]], dtype=int),
            P,
            list(d["names"]),
            None if joints is None else list(joints),
        )

    @classmethod
    def load(cls, path) -> "BaseParameters":
        """Read from JSON written by :meth:`save`; a pinid error naming the file if it is not such a file."""
        return cls.from_dict(read_json(path, "base-parameter"), source=str(path))


#: The marks of a standard parameter: the three of :func:`identifiability`, and "at bound" (a value an
#: estimator held on its constraint, e.g. sdp's friction ≥ 0: :func:`pinid.identification.result.data_marks`).
MARKS = ("identified", "partly", "not identified", "at bound")


def identifiability(P: np.ndarray, tol: float = 1e-9) -> list[str]:
    """Whether the base parameters ``P @ theta`` determine each standard parameter ``theta[i]``.

    ``"identified"``: the unit vector ``e_i`` lies in the row space of ``P`` (the value follows from the
    base parameters alone); ``"not identified"``: ``e_i`` is orthogonal to it (column ``i`` of ``P`` is
    zero: the data carry nothing about it, its value is the prior's, e.g. the URDF's); ``"partly"``:
    otherwise (it enters base combinations with other parameters).  The columns are scaled to unit norm
    first (the answer does not depend on units), then ``‖proj(e_i)‖²`` is compared with 1 and 0 within
    ``tol``."""
    P = as_floats(P, "P")
    if P.ndim != 2:
        raise DataError(f"P: shape {P.shape}, expected (base, standard)")
    norms = np.linalg.norm(P, axis=0)
    scale = norms.max() if norms.size and norms.max() > 0 else 1.0
    zero = norms <= 1e-12 * scale
    if P.shape[0] == 0 or np.all(zero):
        return [MARKS[2]] * P.shape[1]
    Pn = P[:, ~zero] / norms[~zero]
    U, s, Vt = np.linalg.svd(Pn, full_matrices=False)
    V = Vt[s > 1e-10 * s[0]]
    proj = np.sum(V**2, axis=0)  # ‖projection of e_i onto the row space‖², i over the non-zero columns
    out = np.full(P.shape[1], MARKS[2], dtype=object)
    out[~zero] = np.where(proj >= 1 - tol, MARKS[0], np.where(proj <= tol, MARKS[2], MARKS[1]))
    return [str(m) for m in out]


def marks_summary(marks: dict[str, str] | None, names: Sequence[str]) -> str:
    """One line grouping the parameters ``names`` (e.g. ``knee.m`` … ``knee.Izz``) by their mark in ``marks``
    (:meth:`BaseParameters.marks`), short names without the body prefix: ``"identified: mx, Iyy; partly:
    mz; not identified (prior value kept): m, my"``.  Empty when ``marks`` is None or has none of them."""
    if marks is not None and not isinstance(marks, Mapping):
        raise SpecError(f"marks: got {type(marks).__name__}, expected {{standard name: mark}} or None")
    if isinstance(names, str) or not isinstance(names, Sequence) or not all(isinstance(n, str) for n in names):
        raise SpecError(f"names: got {type(names).__name__}, expected a list of standard parameter names")
    if not marks:
        return ""
    groups: dict[str, list[str]] = {k: [] for k in MARKS}
    for n in names:
        if marks.get(n) in groups:
            groups[marks[n]].append(n.split(".", 1)[-1])
    label = {
        MARKS[0]: "identified",
        MARKS[1]: "partly (in combinations)",
        MARKS[2]: "not identified (no information in these data)",
        MARKS[3]: "at bound (held on the estimator's constraint, e.g. friction ≥ 0)",
    }
    return "; ".join(f"{label[k]}: {', '.join(v)}" for k, v in groups.items() if v)


def base_parameters(
    model: RobotModel,
    terms: TermSelection = TermSelection(),
    *,
    samples: int | None = None,
    seed: int = 0,
    tol: float = 1e-8,
    joints: Sequence[str] | None = None,
    rows: str = "all",
) -> BaseParameters:
    """Compute the base parameters of ``model`` with joint ``terms`` from random states (seeded); a floating
    model's from the ``rows`` measured (below).

    ``joints``: only these joints' torque rows are measured (``--fit-joints``): the base parameters are
    those their rows identify (a left-out joint's own friction, say, is not among them).

    A floating model (:class:`~pinid.model.floating.FloatingRobotModel`): those of its standard parameters
    (:func:`~pinid.model.regressor.parameter_names`, base link first) from random free-flyer states; ``rows``
    says which rows are measured: ``"all"`` (the 6 base rows and the joint rows), ``"base"`` (what contact
    wrenches and motion identify without any joint torque) or ``"joints"``.  On a fixed base ``rows`` is "all"."""
    if rows not in ROW_SETS:
        raise SpecError(f"rows={rows!r}, expected one of {', '.join(ROW_SETS)}")
    if isinstance(model, FloatingRobotModel):
        if joints is not None and set(joints) != set(model.joint_names):
            raise SpecError(
                f"joints={list(joints)!r}: not available with a floating base (rows picks base or joint rows)"
            )
        return _free_flyer_base(model, terms, rows, samples, seed, tol)
    model, terms = as_robot(model), as_terms(terms)
    if rows != "all":
        raise SpecError(
            f"rows={rows!r}: the rows of a floating base; {model.name} has a fixed base (expected 'all', or "
            "RobotModel.from_urdf(path, base='floating'))"
        )
    names = parameter_names(model, terms)
    p = len(names)
    tol = number(tol, "tol", low=0, low_open=True, high=0.01)
    n = max(60, 4 * p) if samples is None else count(samples, "samples", low=1)
    if n * model.nv < p:
        raise SpecError(
            f"samples={samples!r}: {n * model.nv} regressor rows for {p} standard parameters, expected "
            f"at least {-(-p // model.nv)} samples (default {max(60, 4 * p)})"
        )
    seed = count(seed, "seed")
    q, dq, ddq = model.random_states(n, np.random.default_rng(seed))
    if any(t in STRIBECK_TERMS for t in terms.names):  # Stribeck columns vanish at speed: slow samples too
        dq = dq * np.logspace(-4, 0, n)[np.random.default_rng(seed).permutation(n)][:, None]
    W = regressor(model, q, dq, ddq, terms)
    fit = None
    if joints is not None and set(joints) != set(model.joint_names):
        fit = [j for j in model.joint_names if j in set(joints)]
        W = W.reshape(n, model.nv, p)[:, [model.joint_names.index(j) for j in fit], :].reshape(-1, p)
    return base_parameters_of(W, names, tol, fit, robot=model.name)


def _free_flyer_base(model: FloatingRobotModel, terms, rows: str, samples, seed, tol) -> BaseParameters:
    """:func:`base_parameters` of a floating model from the rows ``rows`` of random free-flyer states."""
    names = parameter_names(model, terms)
    tol = number(tol, "tol", low=0, low_open=True, high=0.01)
    mask = row_mask(model.nv, rows)
    per = int(mask.sum())
    n = max(60, -(-4 * len(names) // per)) if samples is None else count(samples, "samples", low=1)
    states = random_floating_states(model, n, np.random.default_rng(count(seed, "seed")))
    W = regressor(model, *model.full_state(*states), terms)
    return base_parameters_of(W.reshape(n, -1, len(names))[:, mask].reshape(-1, len(names)), names, tol)


def base_parameters_of(
    W: np.ndarray, names: list[str], tol: float = 1e-8, fit: list[str] | None = None, robot: str = "the robot"
) -> BaseParameters:
    """The base parameters of a stacked standard regressor ``W`` (random states) with columns ``names``;
    ``fit``: the joints whose rows ``W`` holds, when not all (``--fit-joints``)."""
    W = as_floats(W, "W", finite=False)  # no copy of a float array; non-finite columns are named below
    if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
        raise SpecError(f"names: got {type(names).__name__}, expected a list of parameter names")
    p = len(names)
    if W.ndim != 2 or W.shape[1] != p:
        raise DataError(f"W: shape {W.shape}, expected (rows, {p}): one column per name of names ({p} names)")
    with np.errstate(over="ignore", invalid="ignore"):
        norms = np.linalg.norm(W, axis=0)
    bad = [names[i] for i in np.flatnonzero(~np.isfinite(norms))]
    if bad or not np.any(norms > 0):
        raise ModelError(
            f"{robot}: the regressor columns of {', '.join(bad[:4])} overflow (check the model's "
            "numbers: transmission ratios, axes, origins)"
            if bad
            else f"{robot}: every regressor column is zero, expected a model whose joints move its links"
        )
    nonzero = np.flatnonzero(norms > tol * norms.max())
    Wn = W[:, nonzero] / norms[nonzero]
    _, R, piv = scipy.linalg.qr(Wn, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > tol * diag[0]))
    # Which columns to keep: the first independent ones in the natural order (parents' parameters
    # before children's, m before mx … before Izz), so that children's masses fold into their parents'
    # parameters as in the classic hand derivations.  Fall back to the pivots if that set is not of
    # full rank numerically.
    r_natural = np.abs(np.diag(scipy.linalg.qr(Wn, mode="r")[0]))
    independent = nonzero[r_natural > tol**0.5 * 1e-2]  # tol^0.5·1e-2 = 1e-6: clear gap from 1e-14 noise
    if independent.size != rank:
        independent = np.sort(nonzero[piv[:rank]])
    dependent = np.setdiff1d(nonzero, independent)
    P = np.zeros((rank, p))
    P[np.arange(rank), independent] = 1.0
    if dependent.size:
        K, *_ = np.linalg.lstsq(W[:, independent], W[:, dependent], rcond=None)
        K[np.abs(K) < 1e-10 * max(1.0, np.abs(K).max())] = 0.0
        P[:, dependent] = _tidy(K)
    base_names = [names[i] + ("R" if np.count_nonzero(P[r]) > 1 else "") for r, i in enumerate(independent)]
    return BaseParameters(names, independent, P, base_names, fit)


def _tidy(K: np.ndarray) -> np.ndarray:
    """Round coefficients to 12 significant digits so that 0.1764000000003 reads 0.1764."""
    out = K.copy()
    nz = out != 0
    mag = np.floor(np.log10(np.abs(out[nz])))
    out[nz] = np.round(out[nz] / 10**mag, 11) * 10**mag
    return out
