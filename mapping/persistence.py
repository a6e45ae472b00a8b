"""Save and restore a fitted estimator without pickle, and without trusting the file.

scikit-learn conventions make the layout generic: ``__init__`` arguments are the parameters and
fitted state lives in public attributes ending in ``_``. Arrays go into an ``.npz`` under
``<prefix>/<name>``; scalars, parameters and the layout go into JSON. A private list of
*records* (``ManifoldClustering._models``, one
[`ClusterModel`][mapping.manifold.cluster_model.ClusterModel] per cluster, a
``mapping.manifold.graph_cluster_model.GraphClusterModel`` after a k-NN graph fit) is saved field by
field. Attributes of any other type (a split tree kept for inspection) are skipped and listed, so a
loaded estimator predicts exactly like the saved one but cannot be inspected in those respects.

Loading treats the description as untrusted input: only the estimator classes in
`ESTIMATORS` and the record classes in `RECORDS` are ever built, looked up by their
exact name in those tables (never imported by a name from the file); every parameter and field
name must be one the class declares; values must be JSON scalars or arrays that the ``.npz``
holds; records must pass their class's ``validate`` (shapes, finite values, ranges) and the
estimator its ``_check_fitted_state`` (the records agree with the labels and centres).
Anything else raises `PersistenceError` saying what is wrong.
"""

from __future__ import annotations

import dataclasses
import inspect
import re

import numpy as np

from mapping.features import ImageFeatures
from mapping.manifold import ClusterModel, GraphClusterModel, ManifoldClustering

ESTIMATORS = {cls.__name__: cls for cls in (ManifoldClustering, ImageFeatures)}
RECORDS = {cls.__name__: cls for cls in (ClusterModel, GraphClusterModel)}
_FITTED = re.compile(r"[a-z][a-z0-9_]*_\Z")  # public fitted attribute: ends in "_"
_PRIVATE = re.compile(r"_[a-z][a-z0-9_]*[a-z0-9]\Z")  # private list of records
_SCALARS = (bool, int, float, str, type(None))


class PersistenceError(ValueError):
    """A saved estimator description that is malformed or names something not allowed."""


def _scalar(value):
    if isinstance(value, _SCALARS):
        return value
    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        return value.item()
    return NotImplemented


def _jsonable(value):
    # Stricter than common.fileio.jsonable on purpose: a parameter must come back from ``load``
    # as it went in, and load only turns JSON lists into tuples, so arrays and dicts cannot
    # round-trip and are refused here rather than saved and misread.
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    out = _scalar(value)
    if out is NotImplemented:
        raise TypeError(f"cannot save a parameter of type {type(value).__name__}")
    return out


# Parameters added after files of a class were first saved (name -> those parameters).
_ADDED_LATER: dict[str, set[str]] = {
    # the graph path's parameters, then n_jobs
    "ManifoldClustering": {"kernel", "n_neighbors", "n_components", "n_jobs"},
}


def _params(cls) -> list[str]:
    return [p for p in inspect.signature(cls.__init__).parameters if p != "self"]


def _dump_value(value, key: str, arrays: dict) -> dict:
    if isinstance(value, np.ndarray):
        arrays[key] = value
        return {"array": key}
    s = _scalar(value)
    if s is NotImplemented:
        raise TypeError(f"cannot save {key} of type {type(value).__name__}")
    return {"value": s}


def dump(estimator, prefix: str) -> tuple[dict, dict[str, np.ndarray]]:
    """Describe a fitted estimator of a class in `ESTIMATORS` as ``(meta, arrays)``.

    Parameters
    ----------
    estimator : object
        The fitted estimator.
    prefix : str
        Start of the keys of its arrays, ``<prefix>/<name>``.

    Returns
    -------
    meta : dict
        JSON-ready description: ``class``, ``params``, ``fitted``, ``records`` and ``skipped``.
    arrays : dict of str to ndarray
        The arrays the description refers to, by key.
    """
    cls = type(estimator)
    if ESTIMATORS.get(cls.__name__) is not cls:
        raise TypeError(f"cannot save a {cls.__name__}: not one of {sorted(ESTIMATORS)}")
    arrays: dict[str, np.ndarray] = {}
    params = {name: _jsonable(getattr(estimator, name)) for name in _params(cls)}
    fitted, records, skipped = {}, {}, []
    for name, v in vars(estimator).items():
        # numeric arrays only: an object array (feature_names_in_ of a DataFrame fit) would
        # need pickle; it is skipped like any other attribute not needed to predict
        numeric = isinstance(v, np.ndarray) and v.dtype.kind in "biuf"
        if _FITTED.match(name) and (numeric or _scalar(v) is not NotImplemented):
            fitted[name] = _dump_value(v, f"{prefix}/{name}", arrays)
        elif (
            _PRIVATE.match(name)
            and isinstance(v, list)
            and v
            and all(type(x) in RECORDS.values() for x in v)
            and len({type(x) for x in v}) == 1
        ):
            records[name] = {
                "class": type(v[0]).__name__,
                "items": [
                    {
                        f.name: _dump_value(
                            getattr(x, f.name), f"{prefix}/{name}/{i}.{f.name}", arrays
                        )
                        for f in dataclasses.fields(x)
                    }
                    for i, x in enumerate(v)
                ],
            }
        elif _FITTED.match(name) or name.startswith("_"):
            skipped.append(name)
    meta = {
        "class": cls.__name__,
        "params": params,
        "fitted": fitted,
        "records": records,
        "skipped": sorted(skipped),
    }
    return meta, arrays


# -- loading (untrusted) ----------------------------------------------------------------------
def _require(cond: bool, what: str) -> None:
    if not cond:
        raise PersistenceError(what)


def _untuple(value, where: str):
    if isinstance(value, list):
        return tuple(_untuple(v, where) for v in value)
    _require(isinstance(value, _SCALARS), f"{where} must be a JSON scalar or list")
    return value


def _load_value(spec, where: str, arrays: dict[str, np.ndarray], prefix: str):
    _require(
        isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("array", "value"),
        f"{where} must be {{'array': key}} or {{'value': scalar}}, got {spec!r}",
    )
    if "value" in spec:
        _require(isinstance(spec["value"], _SCALARS), f"{where} must hold a JSON scalar")
        return spec["value"]
    key = spec["array"]
    _require(
        isinstance(key, str) and key.startswith(f"{prefix}/") and key in arrays,
        f"{where} names array {key!r}, which the file does not hold",
    )
    value = arrays[key]
    _require(value.dtype.kind in "biuf", f"array {key!r} has dtype {value.dtype}, not numeric")
    return value


def _load_records(spec, where: str, arrays: dict, prefix: str) -> list:
    _require(
        isinstance(spec, dict) and set(spec) == {"class", "items"},
        f"{where} must have exactly the keys 'class' and 'items'",
    )
    cls = RECORDS.get(spec["class"]) if isinstance(spec["class"], str) else None
    _require(
        cls is not None, f"{where} names record class {spec['class']!r}; allowed: {sorted(RECORDS)}"
    )
    names = {f.name for f in dataclasses.fields(cls)}
    # fields the class declares as arrays: a scalar there breaks its methods, not its __init__
    array_fields = {f.name for f in dataclasses.fields(cls) if "ndarray" in str(f.type)}
    _require(isinstance(spec["items"], list) and spec["items"], f"{where}.items must be a list")
    out = []
    for i, item in enumerate(spec["items"]):
        _require(
            isinstance(item, dict) and set(item) == names,
            f"{where}.items[{i}] must have exactly the fields {sorted(names)}",
        )
        fields = {
            k: _load_value(v, f"{where}.items[{i}].{k}", arrays, prefix) for k, v in item.items()
        }
        scalar = sorted(k for k in array_fields if not isinstance(fields[k], np.ndarray))
        _require(
            not scalar,
            f"{where}.items[{i}].{', '.join(scalar)} must be an array "
            "({'array': key}), got a scalar",
        )
        try:
            out.append(cls(**fields))
        except (TypeError, ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            what = f"{where}.items[{i}] is not a valid {cls.__name__}"
            raise PersistenceError(f"{what}: {err}") from err
    return out


def load(cls, meta: dict, arrays: dict[str, np.ndarray], prefix: str):
    """Rebuild an estimator of class ``cls`` (one of `ESTIMATORS`) from `dump`'s output.

    ``meta`` and ``arrays`` are untrusted (see the module docstring).

    Parameters
    ----------
    meta : dict
        The description `dump` gave.
    arrays : dict of str to ndarray
        The arrays it refers to.
    prefix : str
        Where the description sits in the file, for the error messages.

    Returns
    -------
    object
        The estimator, fitted as saved.

    Raises
    ------
    PersistenceError
        If the description is malformed or names something not allowed.
    """
    _require(ESTIMATORS.get(cls.__name__) is cls, f"{cls.__name__} cannot be loaded")
    _require(isinstance(meta, dict), f"{prefix}: the description must be a JSON object")
    keys = {"class", "params", "fitted", "records", "skipped"}
    _require(
        set(meta) == keys, f"{prefix}: expected exactly the keys {sorted(keys)}, got {sorted(meta)}"
    )
    _require(
        meta["class"] == cls.__name__,
        f"{prefix}: the saved estimator is a {meta['class']!r}, not a {cls.__name__}",
    )
    params = meta["params"]
    expected = set(_params(cls))
    # a file saved before a parameter existed lacks it; it then takes its default
    optional = _ADDED_LATER.get(cls.__name__, set())
    _require(
        isinstance(params, dict) and expected - optional <= set(params) <= expected,
        f"{prefix}.params must have exactly the keys {sorted(expected)}",
    )
    try:
        est = cls(**{k: _untuple(v, f"{prefix}.params.{k}") for k, v in params.items()})
        if hasattr(cls, "_parameter_constraints"):  # a scikit-learn estimator: its own checks
            est._validate_params()
    except PersistenceError:
        raise
    except (TypeError, ValueError) as err:
        raise PersistenceError(f"{prefix}.params are not valid for {cls.__name__}: {err}") from err
    _require(isinstance(meta["fitted"], dict), f"{prefix}.fitted must be a JSON object")
    for name, spec in meta["fitted"].items():
        _require(
            isinstance(name, str)
            and bool(_FITTED.match(name))
            and name not in expected
            and not hasattr(cls, name),
            f"{prefix}.fitted: {name!r} is not a fitted attribute name (lower case, ending in _)",
        )
        setattr(est, name, _load_value(spec, f"{prefix}.fitted.{name}", arrays, prefix))
    _require(isinstance(meta["records"], dict), f"{prefix}.records must be a JSON object")
    for name, spec in meta["records"].items():
        _require(
            isinstance(name, str) and bool(_PRIVATE.match(name)) and not hasattr(cls, name),
            f"{prefix}.records: {name!r} is not a private attribute name",
        )
        setattr(est, name, _load_records(spec, f"{prefix}.records.{name}", arrays, prefix))
    _require(
        isinstance(meta["skipped"], list) and all(isinstance(s, str) for s in meta["skipped"]),
        f"{prefix}.skipped must be a list of names",
    )
    check = getattr(est, "_check_fitted_state", None)
    if check is not None:  # the class's own invariants of what it reads when predicting
        try:
            check()
        except (TypeError, ValueError, IndexError) as err:
            raise PersistenceError(f"{prefix}: the fitted state is not valid: {err}") from err
    return est
