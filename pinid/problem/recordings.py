"""Recordings for the identification problem: read (paths with a mapping spec, Datasets, a floating base's
prepared samples) and prepared (:func:`load_datasets`, :func:`prepare_dataset`), the model's free angles unwrapped
(:func:`free_angles`).  One loader whatever the base: a floating model's recordings become their
:class:`~pinid.data.contacts.FloatingSamples` (issue 32)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from pinid.data.contacts import FloatingSamples
from pinid.data.dataset import Dataset, as_dataset
from pinid.data.formats import read_recording
from pinid.data.preprocess import Preprocessing, prepare
from pinid.errors import DataError, SpecError
from pinid.model.floating import FloatingRobotModel
from pinid.model.robot import RobotModel, as_robot


def load_datasets(
    items,
    model: RobotModel,
    mapping=None,
    preprocess: Mapping | bool | None = None,
    what: str = "training",
    *,
    swing_rows: bool = False,
    check=None,
) -> list[Dataset | FloatingSamples]:
    """Recordings (Datasets or paths, one or several) read with ``mapping`` and prepared
    (:func:`prepare_dataset`; for a floating model, into :class:`~pinid.data.contacts.FloatingSamples`); DataError
    when none is given.

    A floating ``model`` (:class:`~pinid.model.floating.FloatingRobotModel`: the loader dispatches on the model, as
    Pinocchio's algorithms do) takes paths, Datasets with floating channels (one built by hand gets ``model`` as
    its ``floating.model``) and prepared :class:`~pinid.data.contacts.FloatingSamples` (kept as they are), and
    always prepares a recording into its FloatingSamples (:func:`pinid.data.preprocess.prepare`, no unwrapping);
    ``swing_rows``: contact phases without a wrench are legs without force sensing
    (:func:`~pinid.data.formats.read_recording`).  ``check``: called with each raw recording before it is
    prepared (a floating base's convention checks, in :func:`pinid.identification.run.setup`)."""
    model = as_robot(model)
    if not isinstance(swing_rows, bool) or (check is not None and not callable(check)):
        raise SpecError("load_datasets: expected swing_rows True or False and check a callable or None")
    if items is None:
        return []
    floating = isinstance(model, FloatingRobotModel)
    if isinstance(items, (Dataset, FloatingSamples, str, os.PathLike)):
        items = [items]
    out = []
    for item in items:
        if floating and isinstance(item, FloatingSamples):
            out.append(item)
            continue
        if not isinstance(item, (Dataset, str, os.PathLike)) or (floating and getattr(item, "floating", 0) is None):
            kinds = (
                "a path, a Dataset with floating channels or FloatingSamples"
                if floating
                else "a Dataset or a recording's path"
            )
            raise DataError(f"{what} recording: got {type(item).__name__}, expected {kinds}")
        more = {"swing_rows": swing_rows} if floating else {}
        ds = item if isinstance(item, Dataset) else read_recording(item, mapping=mapping, model=model, **more)
        if floating and ds.floating.model is None:  # built by hand without one
            ds = replace(ds, floating=replace(ds.floating, model=model))
        if check is not None:
            check(ds)
        if floating:
            out.append(
                prepare(ds, Preprocessing.normalize(preprocess))
            )  # filtered with the options, or as it is with False
        else:
            out.append(prepare_dataset(ds, preprocess, unwrap=free_angles(model)))
    if not out:
        raise DataError(f"no {what} recording given")
    return out


def free_angles(model: RobotModel) -> list[str]:
    """Joints whose angle has no limits (continuous, or revolute without URDF limits): unwrapped in preprocessing."""
    model = as_robot(model)
    return [j.name for j in model.joints if j.kind != "prismatic" and np.isinf(j.lower) and np.isinf(j.upper)]


def prepare_dataset(ds: Dataset, preprocess: Mapping | bool | None = None, *, unwrap=()) -> Dataset:
    """Fill ``dq`` and ``ddq`` when missing (pinid.data.preprocess.prepare with defaults from the sample rate).

    ``preprocess``: None — prepare only recordings without ``dq`` or ``ddq``; a Preprocessing or its dict form
    — always prepare, with these options (``cutoff``, ``preset``, ``trim`` …); False — never.
    ``unwrap``: joints whose angles are unwrapped when the recording is prepared (:func:`free_angles`).
    """
    ds = as_dataset(ds)
    preprocess = _check_preprocess(preprocess)
    needs = ds.dq is None or ds.ddq is None
    if preprocess is False or (preprocess is None and not needs):
        return ds
    options = dict(preprocess) if isinstance(preprocess, dict) else {}
    unwrap = list(dict.fromkeys([*unwrap, *options.pop("unwrap", ())]))  # the model's free angles and the options'
    return prepare(ds, {"unwrap": unwrap, **options})


def _check_preprocess(preprocess) -> dict | bool | None:
    """``preprocess`` in its dict form (:meth:`pinid.data.preprocess.Preprocessing.normalize`); SpecError unless
    it is None, True, False, a Preprocessing or a dict of :func:`pinid.data.preprocess.prepare` options
    (``{"cutof": 5}`` names the unknown key and the known ones)."""
    preprocess = Preprocessing.normalize(preprocess)
    if preprocess is None or isinstance(preprocess, bool):
        return preprocess
    if isinstance(preprocess.get("cutoff"), str):
        raise SpecError(
            f"cut-off {preprocess['cutoff']!r} here: only identify and compare choose the cut-off (auto); "
            "expected a frequency [Hz]"
        )
    Preprocessing.from_dict(preprocess)  # an unknown key, an unwrap that is no list: SpecError naming it
    return preprocess
