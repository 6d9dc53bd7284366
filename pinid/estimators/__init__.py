"""Estimators of the dynamic parameters, one file per family, one registry.

Every estimator follows the contract of :class:`~pinid.estimators.base.Estimator`: ``__init__`` only
stores settings, ``fit(problem)`` returns ``self``, fitted values end in ``_`` (``base_`` always;
``standard_``, ``history_`` when the estimator has them).  Adding one is a file here and one line in
:data:`ESTIMATORS`; another package's is an entry point of the group ``pinid.estimators`` (docs/extending.md).
"""

from __future__ import annotations

from pinid.errors import SpecError
from pinid.estimators.base import Estimator, Setting
from pinid.estimators.didim import DIDIM
from pinid.estimators.essential import Essential
from pinid.estimators.irls import IRLS
from pinid.estimators.iv import InstrumentalVariables
from pinid.estimators.logdet import LogDet
from pinid.estimators.metaheuristic import (
    DEEstimator,
    EWOAEstimator,
    Metaheuristic,
    PSOEstimator,
    RLSPSO,
    SearchBox,
    WOAEstimator,
)
from pinid.estimators.ols import OLS
from pinid.estimators.ridge import Ridge
from pinid.estimators.rls import RLS
from pinid.estimators.sdp import SDP
from pinid.estimators.tls import TLS
from pinid.estimators.wls import WLS
from pinid.plugins import Registry


def _adopt(name: str, cls: object) -> None:
    """Register the estimator class an entry point names (SpecError for anything else)."""
    if not (isinstance(cls, type) and issubclass(cls, Estimator)):
        raise SpecError(f"estimator {name!r}: the entry point names {cls!r}, expected a pinid Estimator subclass")
    ESTIMATORS[name] = cls


#: Registry: method name (as in ``pinid identify --methods``) -> estimator class; other packages add theirs
#: through entry points of the group ``pinid.estimators`` (:class:`pinid.plugins.Registry`).
_BUILTIN: dict[str, type[Estimator]] = {
    "ols": OLS,
    "wls": WLS,
    "sdp": SDP,
    "rls": RLS,
    "pso": PSOEstimator,
    "rls-pso": RLSPSO,
    "woa": WOAEstimator,
    "ewoa": EWOAEstimator,
    "de": DEEstimator,
    "ridge": Ridge,
    "iv": InstrumentalVariables,
    "didim": DIDIM,
    "tls": TLS,
    "irls": IRLS,
    "essential": Essential,
    "logdet": LogDet,
}
ESTIMATORS: Registry = Registry("pinid.estimators", "estimator", adopt=_adopt, entries=_BUILTIN)


def quick_methods() -> list[str]:
    """The registered methods that do not simulate the robot (:attr:`Estimator.simulates`) and are not left
    out of the defaults (:attr:`Estimator.in_defaults`): what ``pinid compare`` and ``pinid demo`` run by default."""
    return [name for name, cls in ESTIMATORS.items() if cls.in_defaults and not cls.simulates]


def make_estimator(name: str, **settings) -> Estimator:
    """An estimator from the registry by name, with checked settings (:meth:`Estimator.create`); SpecError
    for an unknown name or a bad setting."""
    if not isinstance(name, str):
        raise SpecError(f"name: got {type(name).__name__}, expected an estimator name ({', '.join(ESTIMATORS)})")
    key = name.strip().lower()
    if key not in ESTIMATORS:
        raise SpecError(f"unknown method '{name}', expected one of {', '.join(ESTIMATORS)}")
    return ESTIMATORS[key].create(**settings)


__all__ = [
    "DEEstimator",
    "DIDIM",
    "ESTIMATORS",
    "Essential",
    "EWOAEstimator",
    "Estimator",
    "IRLS",
    "InstrumentalVariables",
    "LogDet",
    "Metaheuristic",
    "OLS",
    "PSOEstimator",
    "RLS",
    "RLSPSO",
    "Ridge",
    "SearchBox",
    "SDP",
    "Setting",
    "TLS",
    "WLS",
    "WOAEstimator",
    "make_estimator",
    "quick_methods",
]
