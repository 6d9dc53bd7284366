"""Registries as plug-in points (issue 32): an estimator, a term, an optimiser and a reader of another package,
declared as entry points (faked here: ``importlib.metadata.entry_points`` patched, the package a module in a
temporary folder), are usable by name without importing the package first; pinid's own plug-in terms load
from its entry points (the installed metadata, or the source tree's pyproject.toml)."""

from __future__ import annotations

import importlib.metadata
import re
import sys
import textwrap
import warnings

import pytest

from pinid.data.registry import READERS
from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, make_estimator
from pinid.model.terms import PLUGIN_TERMS, TERMS, as_terms
from pinid.optimizers import OPTIMIZERS, get_optimizer
from pinid.plugins import GROUPS, PluginWarning, Registry, declared

MODULE = textwrap.dedent(
    """
    import numpy as np

    from pinid.data.registry import Reader, READERS
    from pinid.estimators.ols import OLS
    from pinid.model.terms import Term, register
    from pinid.optimizers.pso import PSO


    class MedianLS(OLS):
        name = "fake-median"
        description = "a fake out-of-tree estimator (OLS under another name)"


    class FakeSwarm(PSO):
        pass


    FAKE_READER = Reader("fakefmt", READERS["csv"].read, suffixes=(".fakefmt",), columns=READERS["csv"].columns)
    """
)
TERM_MODULE = textwrap.dedent(
    """
    import numpy as np

    from pinid.model.terms import Term, register

    register(Term("fake_backlash", "backlash", "fake backlash", "N·m", lambda m: np.tanh(m.dq)))
    """
)
FAKES = {
    "pinid.estimators": [("fake-median", "fake_pinid_plugin:MedianLS")],
    "pinid.terms": [("fake_backlash", "fake_pinid_terms")],
    "pinid.optimizers": [("fake-swarm", "fake_pinid_plugin:FakeSwarm")],
    "pinid.readers": [("fakefmt", "fake_pinid_plugin:FAKE_READER")],
}
REGISTRIES = (ESTIMATORS, TERMS, OPTIMIZERS, READERS)


@pytest.fixture
def fake_package(tmp_path, monkeypatch):
    """A package of plug-ins, importable and declared through faked entry points; forgotten afterwards."""
    (tmp_path / "fake_pinid_plugin.py").write_text(MODULE, encoding="utf-8")
    (tmp_path / "fake_pinid_terms.py").write_text(TERM_MODULE, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    real = importlib.metadata.entry_points

    def entry_points(**kw):
        group = kw.get("group")
        own = [importlib.metadata.EntryPoint(n, v, group) for n, v in FAKES.get(group, [])]
        return [*real(**kw), *own]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    for r in REGISTRIES:
        r.refresh()
    yield
    monkeypatch.undo()
    for r in REGISTRIES:
        for name, _ in FAKES[r.group]:
            if r.registered(name):
                del r[name]
        r.refresh()
    for m in ("fake_pinid_plugin", "fake_pinid_terms"):
        sys.modules.pop(m, None)


def test_an_out_of_tree_estimator_is_usable_by_name(fake_package):
    from pinid.identification.run import parse_methods

    assert "fake-median" in list(ESTIMATORS) and "fake_pinid_plugin" not in sys.modules  # listed, not loaded
    assert parse_methods("ols,fake-median") == ["ols", "fake-median"]
    est = make_estimator("fake-median")
    assert type(est).__name__ == "MedianLS" and "fake_pinid_plugin" in sys.modules


def test_the_cli_methods_option_takes_an_out_of_tree_estimator(request):
    from pinid.cli.main import build_parser
    from pinid.identification.run import parse_methods

    build_parser()  # the commands' modules imported before the fake package: their texts must not keep it
    request.getfixturevalue("fake_package")
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    help_text = re.sub(r"\s+", "", sub.choices["identify"].format_help())  # argparse wraps at spaces and hyphens
    assert "fake-median" in help_text and "fake_backlash(fakebacklash)" in help_text  # --methods, --terms
    args = parser.parse_args(["identify", "--methods", "ols,fake-median"])
    assert parse_methods(args.methods) == ["ols", "fake-median"]


def test_an_out_of_tree_term_is_usable_by_name(fake_package):
    assert "fake_pinid_terms" not in sys.modules
    terms = as_terms("fc,fv,fake_backlash")
    assert terms.names == ["fc", "fv", "fake_backlash"] and TERMS.plugin("fake_backlash")
    assert list(TERMS)[-1] == "fake_backlash"  # another package's term goes after pinid's own


def test_an_out_of_tree_term_of_a_saved_robot_loads_without_an_import(fake_package):
    from pinid.model.robot import RobotModel
    from pinid.model.serialize import robot_from_dict, robot_to_dict

    saved = robot_to_dict(RobotModel.from_urdf("exo_leg"), as_terms("fc,fake_backlash"))
    TERMS.refresh()
    del TERMS["fake_backlash"]
    sys.modules.pop("fake_pinid_terms")
    _, terms = robot_from_dict(saved)
    assert terms.names == ["fc", "fake_backlash"]


def test_an_out_of_tree_optimizer_and_reader_are_usable_by_name(fake_package, tmp_path):
    from pinid.data.registry import reader_for

    assert type(get_optimizer("fake-swarm", population=4, iterations=2)).__name__ == "FakeSwarm"
    file = tmp_path / "run.fakefmt"
    file.write_text("t,q_a\n0,1\n", encoding="utf-8")
    assert reader_for(file).name == "fakefmt" and reader_for(file, "fakefmt").name == "fakefmt"


def test_a_broken_plug_in_is_named_when_asked_for_and_left_out_of_listings(monkeypatch):
    real = importlib.metadata.entry_points

    def entry_points(**kw):
        extra = [importlib.metadata.EntryPoint("broken", "no_such_module_xyz", kw["group"])]
        return [*real(**kw), *(extra if kw.get("group") == "pinid.estimators" else [])]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    ESTIMATORS.refresh()
    try:
        assert "broken" in list(ESTIMATORS)  # listed: not loaded yet
        with pytest.warns(PluginWarning, match="no_such_module_xyz"):
            assert "broken" not in dict(ESTIMATORS.items())  # loaded with the others: left out, a warning
        ESTIMATORS.refresh()
        with pytest.raises(SpecError, match="entry point broken = 'no_such_module_xyz' of group pinid.estimators"):
            make_estimator("broken")
        assert "broken" not in list(ESTIMATORS)  # tried: no longer listed
    finally:
        monkeypatch.undo()
        ESTIMATORS.refresh()
    assert "broken" not in list(ESTIMATORS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ESTIMATORS.load_all()


def test_an_entry_point_naming_a_wrong_object_is_refused(monkeypatch):
    real = importlib.metadata.entry_points

    def entry_points(**kw):
        extra = [importlib.metadata.EntryPoint("notanest", "numpy:ndarray", kw["group"])]
        return [*real(**kw), *(extra if kw.get("group") == "pinid.estimators" else [])]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    ESTIMATORS.refresh()
    try:
        with pytest.raises(SpecError, match="expected a pinid Estimator subclass"):
            make_estimator("notanest")
    finally:
        monkeypatch.undo()
        ESTIMATORS.refresh()
    assert "notanest" not in ESTIMATORS and isinstance(ESTIMATORS, Registry)


def test_pinid_declares_its_plug_in_terms_as_entry_points():
    """Every in-tree plug-in term has an entry point (installed metadata or the source tree's
    pyproject.toml) and loads through it; nothing else of pinid's groups is declared that does not load."""
    for group in GROUPS:
        declared(group)
    terms = declared("pinid.terms")
    assert set(PLUGIN_TERMS) <= set(terms), sorted(set(PLUGIN_TERMS) - set(terms))
    for name in PLUGIN_TERMS:
        assert TERMS[name].name == name
    assert list(TERMS)[: len(PLUGIN_TERMS) + 6][6:] == list(PLUGIN_TERMS)  # their places: after fc … fc_neg


def test_declared_refuses_an_unknown_group():
    with pytest.raises(SpecError, match="group"):
        declared("pinid.nothing")
    with pytest.raises(SpecError, match="group"):
        declared(3)
