"""The contract every registered joint or motor term keeps (issue 26): iterated over
:data:`pinid.model.terms.TERMS`, so a new term is checked without editing this file.  ``check_term`` also runs
on the worked example of docs/architecture.md ("Adding a joint term"), registered at runtime.

For each term, alone on exo_leg with a coupled transmission (hip motor → knee, so motor terms reach both joint
rows through Gᵀ), at random states away from rest (velocities in the term's own space, 0.02…2 rad/s):

* the regressor times (inertial parameters, known term values) is RNEA plus the term's **law**: its plant law
  (what the digital twin applies, e.g. Coulomb ``fc·tanh(dq/v_s)``) in the limit of no smoothing, or
  value × column when it has none, in its own space (joint, or motor mapped by Gᵀ);
* the known values are recovered by least squares from that torque (ground truth);
* the flags say what the column is: an ``inertia`` column is the acceleration (the plant adds the value to the
  mass matrix), a ``static`` one depends on q only, a ``velocity_step`` one jumps at zero velocity only;
* nominal values have one entry per joint (motor) and respect ``nonnegative``; parameter names end with the
  suffix.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pinid import regressor
from pinid.model import terms as T
from pinid.model.drives import Drives, Transmission
from pinid.model.robot import RobotModel

G = np.array([[30.0, 0.0], [12.0, 25.0]])  # cable: the knee motor turns with the hip too
SMOOTH = 1e-9  # [rad/s]: plant laws with this smoothing are their unsmoothed law away from rest


def robot() -> RobotModel:
    m = RobotModel.from_urdf("exo_leg")
    values = {"m_hip": {"fc": 0.04, "fv": 0.004}, "m_knee": {"fc": 0.05, "fv": 0.003}}
    return m.with_drives(Drives(m.joint_names, [Transmission(m.joint_names, ["m_hip", "m_knee"], G)], values, "test"))


def states(m: RobotModel, space: str, n: int = 60, seed: int = 0):
    """Random states; velocities in the term's own space (joint, or motor ``G·dq``) away from rest, of both
    signs, log-uniform over 0.02…2 rad/s so that velocity-shaped laws (Stribeck) are seen at every scale."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array([j.lower for j in m.joints]), np.array([j.upper for j in m.joints])
    q = lo + (hi - lo) * rng.uniform(0.1, 0.9, (n, m.nv))
    v = rng.choice([-1.0, 1.0], (n, m.nv)) * np.exp(rng.uniform(np.log(0.02), np.log(2.0), (n, m.nv)))
    dq = v if space == "joint" else np.linalg.solve(G, v.T).T
    ddq = rng.normal(0.0, 3.0, (n, m.nv))
    return q, dq, ddq


def law(term: T.Term, values: np.ndarray, motion: T.Motion) -> np.ndarray:
    """The term's torque in its own space by its plant law (unsmoothed limit), else value × column."""
    if term.plant is not None:
        return term.plant(values, motion, SMOOTH)
    return values * term.column(motion)


def check_term(name: str, m: RobotModel | None = None) -> None:
    """Every clause of the contract for the registered term ``name`` (on ``m``, default :func:`robot`)."""
    term = T.TERMS[name]
    m = robot() if m is None else m
    sel = T.TermSelection(names=[name])
    q, dq, ddq = states(m, term.space)
    n_own = m.nv if term.space == "joint" else len(m.drives.motor_names)
    names = T.term_parameter_names(m, sel)
    assert len(names) == n_own and all(p.endswith("." + term.suffix) for p in names)

    # regressor · (inertial, known values) = RNEA + the term's law, mapped into joint space
    values = np.random.default_rng(1).uniform(0.5, 1.5, n_own)
    W = regressor(m, q, dq, ddq, sel)
    theta = np.concatenate([m.inertial_parameters(), values])
    motion = T.motion(m, q, dq, ddq, term.space)
    own = law(term, values, motion)
    assert own.shape == (len(q), n_own)
    joint = own if term.space == "joint" else own @ m.drives.matrix
    want = m.rnea(q, dq, ddq) + joint
    np.testing.assert_allclose((W @ theta).reshape(want.shape), want, rtol=1e-9, atol=1e-9)
    # ground truth: the values come back by least squares from the law's torque
    Wt = W[:, 10 * m.nv :]
    back = np.linalg.lstsq(Wt, joint.reshape(-1), rcond=None)[0]
    live = np.abs(Wt).sum(axis=0) > 0  # a column zero everywhere (passive on a joint with no anatomy) tells nothing
    assert live.any(), f"{name}: the term's column is zero at every state"
    np.testing.assert_allclose(back[live], values[live], rtol=1e-8)

    # the flags describe the column
    column = term.column(motion)
    still = motion._replace(dq=2 * motion.dq, ddq=-motion.ddq)
    if term.inertia:
        np.testing.assert_array_equal(column, motion.ddq)
    if term.static:
        np.testing.assert_array_equal(term.column(still), column)
    if term.velocity_step:  # a jump at zero velocity, constant on each side: unchanged when |dq| doubles
        np.testing.assert_array_equal(term.column(motion._replace(dq=2 * motion.dq)), column)
        assert not np.array_equal(term.column(motion._replace(dq=-motion.dq)), column)

    # nominal values: one per joint (motor), ≥ 0 where the term must be
    if term.nominal is not None:
        nominal = np.asarray(term.nominal(m), dtype=float)
        assert nominal.shape == (n_own,) and np.all(np.isfinite(nominal))
        if term.nonnegative:
            assert np.all(nominal >= 0)
    assert T.nominal(m, sel).shape == (n_own,)


@pytest.mark.parametrize("name", list(T.TERMS))
def test_every_registered_term_acts_through_its_law(name):
    check_term(name)


# ---------------------------------------------------------------------------------------------- new terms
def test_the_suite_catches_a_plant_that_disagrees_with_its_column():
    term = T.register(T.Term("toy_wrong", "w", "wrong", "N·m", lambda mo: mo.dq, plant=lambda v, mo, vs: 2 * v * mo.dq))
    try:
        with pytest.raises(AssertionError):
            check_term("toy_wrong")
    finally:
        T.TERMS.pop(term.name)


def architecture_example(heading: str) -> str:
    """The python block of the section ``heading`` of docs/architecture.md (its worked example; compiled
    with ``dont_inherit`` so that it runs as a file of its own, without this file's ``__future__`` import)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def run_architecture_example() -> None:
    """Run docs/architecture.md's "Adding a joint term" block as written (it registers the term ``spring``)."""
    assert "spring" not in T.TERMS
    exec(
        compile(architecture_example("Adding a joint term"), "docs/architecture.md", "exec", dont_inherit=True),
        {"__name__": "example"},
    )


def test_the_worked_example_of_docs_architecture_keeps_the_contract():
    """docs/architecture.md's "Adding a joint term" block, run as written, registers a term that passes."""
    try:
        run_architecture_example()
        check_term("spring")
        assert "spring" in T.TermSelection.from_names("fc,spring")  # selected like any other
    finally:
        T.TERMS.pop("spring", None)


def test_the_setting_of_the_worked_example_is_saved_with_the_model_without_editing_serialize():
    """The docs example's rest angle is a model setting: the term keeps the contract with it set, the column
    reads it, and robot_to_dict / robot_from_dict save and read it back through the term alone."""
    import json

    from pinid.model import serialize

    try:
        run_architecture_example()
        m = robot().with_setting("spring_rest", 0.2)
        check_term("spring", m)
        at_rest = np.full((1, m.nv), 0.2)
        np.testing.assert_array_equal(T.TERMS["spring"].column(T.motion(m, at_rest, 0 * at_rest, 0 * at_rest)), 0.0)
        saved = json.loads(json.dumps(serialize.robot_to_dict(m, T.TermSelection(names=["fc", "spring"]))))
        assert saved["spring_rest"] == 0.2
        back, terms = serialize.robot_from_dict(saved)
        assert back.setting("spring_rest") == 0.2 and terms.names == ["fc", "spring"]
        assert "spring_rest" not in serialize.robot_to_dict(robot(), terms)  # absent when the model sets none
        assert robot_default_rest(serialize.robot_from_dict({**saved, "spring_rest": None})[0]) == 0.0
        assert "spring_rest" not in Path(serialize.__file__).read_text(encoding="utf-8")
    finally:
        T.TERMS.pop("spring", None)


def robot_default_rest(m: RobotModel) -> float:
    """The rest angle the docs example's term sees on ``m``: 0 where the model does not set it."""
    zero = np.zeros((1, m.nv))
    return float(-T.TERMS["spring"].column(T.motion(m, zero, zero, zero))[0, 0])


def test_the_old_name_joint_terms_still_works_with_a_deprecation_warning():
    """``JointTerms`` was renamed ``TermSelection`` (it selects motor and plug-in terms too): the old name
    still works for one release, from every place it was imported, with a DeprecationWarning."""
    import pinid
    import pinid.model.regressor
    import pinid.model.terms
    from pinid.model.terms import TermSelection

    for module in (pinid, pinid.model.regressor, pinid.model.terms):
        with pytest.warns(DeprecationWarning, match="JointTerms is deprecated, use TermSelection"):
            assert module.JointTerms is TermSelection
