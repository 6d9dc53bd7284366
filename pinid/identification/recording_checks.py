"""Checks on the recordings given to a study before any is read: each given once (by path or content), a
validation recording not a training one, a payload recording not a training one, and the memory the training
recordings will need (:func:`pinid.identification.run.identify` and :func:`pinid.wearer.stage` call them)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from pinid.data.dataset import Dataset, as_dataset
from pinid.errors import DataError
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import TermSelection, as_terms


def bytes_per_sample(model: RobotModel, terms: TermSelection) -> float:
    """About how much memory ``identify`` needs per training sample [bytes] with the default methods: the
    recording (8·(1 + 4·nv): t, q, dq, ddq, tau), its kept torque rows, their joints and which are kept
    (10·nv) and the arrays of rows of the moment (24·nv: a residual with the metrics' scratch or wls's
    weights, and the heap around them); the regressor itself is built in blocks (issue 35).  Measured on
    exo_leg, ols,wls,sdp: 103 B per sample between 100 000 and 1 000 000 samples, 132 B above the imports at
    10 000 000 (estimate 140).  rls, the metaheuristics, the segmental strategy, the Stribeck search and drive
    gains build the tall regressor whole (8·nv·nb more, ``terms`` sets nb).  docs/benchmarks.md "Memory"."""
    model, _ = as_robot(model), as_terms(terms)
    return 8.0 * (1 + 4 * model.nv) + 34.0 * model.nv


def warn_if_large_recordings(model: RobotModel, terms: TermSelection, datasets: Sequence[Dataset]) -> bool:
    """One-line DataWarning when the training recordings would need more than half the available
    memory (:func:`bytes_per_sample`); True if warned."""
    model, terms = as_robot(model), as_terms(terms)
    from pinid.memory import warn_if_large

    if not isinstance(datasets, Iterable):
        raise DataError(f"datasets: got {type(datasets).__name__}, expected a list of Datasets")
    samples = sum(len(as_dataset(ds, "datasets").t) for ds in datasets)
    if samples < 20_000:  # below ~100 MB for any robot pinid has met: not worth asking the system
        return False
    per = bytes_per_sample(model, terms)
    return warn_if_large(per * samples, f"{samples:,} training samples of {model.name}", per_item=per)


def recording_items(recordings) -> list:
    """The recordings given as one or several (Datasets, paths)."""
    if recordings is None:
        return []
    if isinstance(recordings, (Dataset, str, os.PathLike)):
        return [recordings]
    return list(recordings) if isinstance(recordings, Iterable) else [recordings]


def _keys(item) -> list[tuple]:
    """What makes two recordings the same one: the resolved path or the contents (SHA-256) of a file,
    or the Dataset object."""
    if not isinstance(item, (str, os.PathLike)):
        return [("object", id(item))]
    keys: list[tuple] = [("path", os.path.realpath(item))]
    try:
        if os.path.isfile(item):
            import hashlib

            digest = hashlib.sha256()
            with open(item, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    digest.update(block)
            keys.append(("content", os.path.getsize(item), digest.hexdigest()))
    except OSError:  # unreadable: the reader says so with the file's name
        pass
    return keys


def check_distinct(data, validate=None, *, what: str = "training data") -> None:
    """DataError for a recording given twice as ``what`` (its rows would count twice: the standard
    deviations shrink by √2 with no new information), by path (symbolic links resolved) or by content (a
    copy); the same for a validation recording given twice in one group; a DataWarning for a validation
    recording that is also a training one (then the validation error is a training error)."""
    if data is None:
        raise DataError("data: got None, expected recordings (Datasets or paths)")
    for item in recording_items(data):
        if not isinstance(item, (Dataset, str, os.PathLike)):
            raise DataError(f"data: got {type(item).__name__}, expected recordings (Datasets or paths)")
    from pinid.data.formats import warn

    seen = _distinct(recording_items(data), what)
    groups = validate.values() if isinstance(validate, Mapping) else [validate]
    for g in groups:
        _distinct(recording_items(g), "validation data")
    for item in (i for g in groups for i in recording_items(g)):
        if any(k in seen for k in _keys(item)):
            warn(
                None,
                f"{item}: the validation recording is also a training recording, so its error is a "
                "training error, not a validation; expected a different trajectory",
            )


def _distinct(items: list, what: str) -> dict:
    """``{key: item}`` of ``items``; DataError naming both when two are one recording (:func:`_keys`)."""
    seen: dict = {}
    for item in items:
        for k in _keys(item):
            if k in seen:
                how = "" if k[0] != "content" else " (same contents)"
                raise DataError(f"{item}: given twice as {what} (also {seen[k]}{how}); expected each recording once")
        for k in _keys(item):
            seen[k] = item
    return seen


# ====================================================================== identify
def check_payload_data_distinct(data, payload_data) -> None:
    """DataError when a recording with the payload is also a training recording (the same path or
    Dataset, or, once read, the same samples): without a difference between them the gains are
    undetermined and the fit reports a meaningless "non-positive gain"."""
    training = recording_items(data)
    for item in recording_items(payload_data):
        for other in training:
            same = bool(set(_keys(item)) & set(_keys(other)))
            if not same and isinstance(item, Dataset) and isinstance(other, Dataset):
                same = all(
                    a is not None and b is not None and a.shape == b.shape and np.array_equal(a, b)
                    for a, b in ((item.t, other.t), (item.q, other.q), (item.tau, other.tau))
                )
            if same:
                raise DataError(
                    f"{getattr(item, 'source', item)}: the recording with the payload (--payload-data) is also "
                    f"a training recording (--data {getattr(other, 'source', other)}); expected a recording "
                    "made with the payload fixed to the link, which differs from the one without it"
                )
