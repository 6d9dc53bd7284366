"""The identification problem: the stacked regressor rows of recordings, their weights and base map
(:mod:`pinid.problem.problem`), which rows enter the fit (:mod:`pinid.problem.rows`) and the floating-base
problem (:mod:`pinid.problem.floating`).  It sits below the estimators, which fit it."""
