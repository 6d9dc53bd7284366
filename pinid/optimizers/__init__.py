"""Population-based optimisers behind one interface (see :mod:`pinid.optimizers.base`).

They minimise a batch function ``f(X) -> (P,)`` of a population ``X (P, d)`` inside a box, with a seeded
``numpy.random.Generator``, and return an :class:`OptimizeResult` (best point, value, best value per
iteration, evaluations, time).  Excitation design (:mod:`pinid.excitation.design`) and identification reuse
them.  Adding an optimiser is one file plus one line in :data:`OPTIMIZERS`; another package's is an entry point
of the group ``pinid.optimizers`` (docs/extending.md).

=========  ===========================================================================
name       method
=========  ===========================================================================
``pso``    particle swarm, linearly decreasing inertia weight (seed 000 Eqs. (7)-(8))
``woa``    whale optimisation (seed 001 Eqs. (14)-(17))
``ewoa``   whale optimisation + differential mutation of the better whales (seed 001 Eq. (18))
``de``     scipy's differential evolution, vectorised
=========  ===========================================================================

Two methods are offered by name beside the registry but are not optimisers of this interface:
``slsqp`` (the default of excitation design, :func:`pinid.excitation.design.design_excitation`) and
``least_squares`` (the output-error fit of flexible joints, :func:`pinid.flexible.output_error.fit_output_error`;
scipy's trust-region least squares also polishes the metaheuristic estimators).  Both are gradient-based
*local* methods: slsqp needs the design problem's analytic gradient and its inequality constraints
(a multistart with its own ``starts`` setting), least_squares a residual vector and its Jacobian.  The
interface here is derivative-free minimisation of a batch *scalar* function in a box, which gives them
neither; their callers list them beside :data:`OPTIMIZERS` (``design_optimizers()``,
``output_error.methods()``), and the contract suite (tests/contracts/test_optimizer_contract.py) covers the registry.
"""

from __future__ import annotations

from pinid.errors import SpecError
from pinid.optimizers.base import OptimizeResult, Optimizer
from pinid.optimizers.de import DEOptions, DifferentialEvolution
from pinid.optimizers.pso import PSO, PSOOptions
from pinid.optimizers.woa import EWOA, WOA, EWOAOptions, WOAOptions
from pinid.plugins import Registry


def _adopt(name: str, cls: object) -> None:
    """Register the optimiser class an entry point names (SpecError for anything else)."""
    if not (isinstance(cls, type) and issubclass(cls, Optimizer)):
        raise SpecError(f"optimizer {name!r}: the entry point names {cls!r}, expected a pinid Optimizer subclass")
    OPTIMIZERS[name] = cls


_BUILTIN: dict[str, type[Optimizer]] = {
    "pso": PSO,
    "woa": WOA,
    "ewoa": EWOA,
    "de": DifferentialEvolution,
}
#: Optimisers by name; other packages add theirs through entry points of the group ``pinid.optimizers``.
OPTIMIZERS: Registry = Registry("pinid.optimizers", "optimizer", adopt=_adopt, entries=_BUILTIN)


def get_optimizer(name: str, options=None, **kw) -> Optimizer:
    """An optimiser by registry name, with its options dataclass and/or keyword settings.

    ``get_optimizer("pso", population=50, iterations=100)``; unknown names or options raise SpecError.
    """
    try:
        cls = OPTIMIZERS[name.lower()]
    except (KeyError, AttributeError):
        raise SpecError(f"unknown optimizer {name!r}, expected one of {', '.join(OPTIMIZERS)}") from None
    return cls(options, **kw)


__all__ = [
    "DEOptions",
    "DifferentialEvolution",
    "EWOA",
    "EWOAOptions",
    "OPTIMIZERS",
    "OptimizeResult",
    "Optimizer",
    "PSO",
    "PSOOptions",
    "WOA",
    "WOAOptions",
    "get_optimizer",
]
