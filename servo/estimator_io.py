"""Save and restore a fitted estimator without pickle: parameters, fitted attributes, and
private lists of dataclasses (e.g. ``ManifoldClustering``'s per-cluster models) field by field.

scikit-learn conventions make this generic: ``__init__`` arguments are the parameters and
fitted state lives in attributes ending in ``_``. Arrays go into an ``.npz`` under
``<prefix>/<name>``; scalars, parameters and the layout go into JSON. Attributes of any other
type (a split tree kept for inspection) are skipped and listed, so a loaded estimator predicts
exactly like the saved one but cannot be inspected in those respects.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect

import numpy as np

# Only dataclasses from these packages are rebuilt on load: a crafted file cannot make us
# import and instantiate arbitrary classes.
_TRUSTED_MODULES = ("mapping.",)


def _scalar(value):
    if isinstance(value, bool | int | float | str) or value is None:
        return value
    if isinstance(value, np.generic):
        return value.item()
    return NotImplemented


def _jsonable(value):
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    return _scalar(value)


def _untuple(value):
    return tuple(_untuple(v) for v in value) if isinstance(value, list) else value


def _dump_dataclass(obj, key: str, arrays: dict) -> dict:
    fields = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray):
            arrays[f"{key}.{f.name}"] = v
            fields[f.name] = {"array": f"{key}.{f.name}"}
        else:
            s = _scalar(v)
            if s is NotImplemented:
                raise TypeError(f"cannot save field {f.name} of {type(obj).__name__}")
            fields[f.name] = {"value": s}
    cls = type(obj)
    return {"class": f"{cls.__module__}:{cls.__qualname__}", "fields": fields}


def dump(estimator, prefix: str) -> tuple[dict, dict[str, np.ndarray]]:
    """``(meta, arrays)`` describing a fitted estimator; see :func:`load`."""
    arrays: dict[str, np.ndarray] = {}
    params = {
        name: _jsonable(getattr(estimator, name))
        for name in inspect.signature(type(estimator).__init__).parameters
        if name != "self"
    }
    scalars, lists, skipped = {}, {}, []
    for name, v in vars(estimator).items():
        fitted = name.endswith("_") and not name.startswith("_")
        if fitted and isinstance(v, np.ndarray):
            arrays[f"{prefix}/{name}"] = v
        elif fitted and _scalar(v) is not NotImplemented:
            scalars[name] = _scalar(v)
        elif (
            name.startswith("_")
            and not name.startswith("__")
            and isinstance(v, list)
            and v
            and all(dataclasses.is_dataclass(x) for x in v)
        ):
            lists[name] = [
                _dump_dataclass(x, f"{prefix}/{name}/{i}", arrays) for i, x in enumerate(v)
            ]
        elif fitted or name.startswith("_"):
            skipped.append(name)
    meta = {
        "class": type(estimator).__name__,
        "params": params,
        "scalars": scalars,
        "arrays": sorted(k.split("/", 1)[1] for k in arrays if k.count("/") == 1),
        "lists": lists,
        "skipped": sorted(skipped),
    }
    return meta, arrays


def _class(path: str):
    module, _, qualname = path.partition(":")
    if not module.startswith(_TRUSTED_MODULES):
        raise ValueError(f"refusing to rebuild class {path!r} from a saved estimator")
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def load(cls, meta: dict, arrays: dict[str, np.ndarray], prefix: str):
    """Rebuild an estimator of class ``cls`` from :func:`dump`'s output."""
    if meta["class"] != cls.__name__:
        raise ValueError(f"saved estimator is a {meta['class']}, not a {cls.__name__}")
    est = cls(**{k: _untuple(v) for k, v in meta["params"].items()})
    for name, v in meta["scalars"].items():
        setattr(est, name, v)
    for name in meta["arrays"]:
        setattr(est, name, arrays[f"{prefix}/{name}"])
    for name, items in meta["lists"].items():
        objs = []
        for item in items:
            kwargs = {
                f: arrays[spec["array"]] if "array" in spec else spec["value"]
                for f, spec in item["fields"].items()
            }
            objs.append(_class(item["class"])(**kwargs))
        setattr(est, name, objs)
    return est
