"""Methods from outside the repository: ``package.module:Class`` plus ``--param k=v``.

Loading a method imports its module the way ``python -m`` would: the module's top-level code
runs, with the current directory on the import path. Name only code you trust.
"""

from __future__ import annotations

import ast
import inspect
import math
import re

from common.user_modules import UserModuleError, import_user_module, source_digest

__all__ = ["OutsideMethod", "load_method", "parse_params"]

_SPEC = re.compile(r"^([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*):([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)$")


def parse_params(items) -> dict:
    """Parse ``["k=v", ...]`` into a dict.

    Each value is a Python literal (``3``, ``0.5``, ``'rbf'``, ``None``, ``(1, 2)``) or,
    failing that, the text itself.

    Parameters
    ----------
    items : iterable of str or None
        The ``KEY=VALUE`` items; None for none.

    Returns
    -------
    dict
        Each key with its value.

    Raises
    ------
    ValueError
        For a key given twice, an item without ``=``, a key that is no identifier or a
        non-finite number.
    """
    params = {}
    for item in items or ():
        key, sep, text = str(item).partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise ValueError(f"--param must be KEY=VALUE with KEY a Python name, got {item!r}")
        if key in params:
            raise ValueError(f"--param {key} is given twice")
        try:
            value = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError, MemoryError, RecursionError):
            value = text.strip()
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"--param {key} must be finite, got {text!r}")
        params[key] = value
    return params


class OutsideMethod:
    """A class named ``package.module:Class`` with the methods its task calls.

    Parameters
    ----------
    spec : str
        ``package.module:Class`` (``Class`` may be dotted: ``module:Outer.Inner``).
    required : tuple of str
        Methods the class must have (``("fit",)``).
    params : dict, optional
        Keyword arguments for the constructor; checked against its signature.
    """

    def __init__(self, spec: str, required: tuple[str, ...], params: dict | None = None):
        self.spec = spec
        self.cls = load_method(spec, required)
        self.params = dict(params or {})
        self._signature = _init_parameters(self.cls)
        if self._signature is not None:
            unknown = sorted(set(self.params) - set(self._signature))
            if unknown:
                raise ValueError(
                    f"{spec} takes no parameter {unknown[0]!r} (it takes {sorted(self._signature)})"
                )

    @property
    def name(self) -> str:
        """The class's name."""
        return self.cls.__name__

    def accepts(self, parameter: str) -> bool:
        """Check whether the constructor takes ``parameter``.

        Parameters
        ----------
        parameter : str
            A keyword parameter's name.

        Returns
        -------
        bool
            Whether the constructor takes it (True where it takes ``**kwargs`` or has no
            readable signature).
        """
        return self._signature is None or parameter in self._signature

    def make(self, **defaults):
        """Make a new instance with ``params``.

        Parameters
        ----------
        **defaults
            Values (e.g. the protocol's ``n_clusters``) that fill in what the user did not
            set, where the constructor takes them.

        Returns
        -------
        object
            The new instance of the class.
        """
        given = {k: v for k, v in defaults.items() if k not in self.params and self.accepts(k)}
        return self.cls(**given, **self.params)

    def describe(self, **defaults) -> dict:
        """Describe the method as the method block of a result file.

        Parameters
        ----------
        **defaults
            The protocol's values, as given to ``make``.

        Returns
        -------
        dict
            ``name``, ``spec``, every parameter passed (``params``), which of them the
            protocol chose (``protocol_params``: left out of the method's label) and the
            digest of the module's source (``source``: ``common.user_modules.source_digest``).
        """
        given = {k: v for k, v in defaults.items() if k not in self.params and self.accepts(k)}
        return {
            "name": self.name,
            "spec": self.spec,
            "params": {**given, **self.params},
            "protocol_params": sorted(given),
            "source": source_digest(self.spec.partition(":")[0]),
        }


def load_method(spec: str, required: tuple[str, ...] = ("fit",)):
    """Load the class named by ``spec``, imported like ``python -m`` would.

    The current directory comes first on the import path.

    Parameters
    ----------
    spec : str
        ``package.module:Class`` (``Class`` may be dotted).
    required : tuple of str, default ("fit",)
        Methods the class must have.

    Returns
    -------
    type
        The class.

    Raises
    ------
    ValueError
        When the spec is malformed, the module does not import, the name is missing or not a
        class, or the class lacks one of ``required``.
    """
    if not isinstance(spec, str) or not _SPEC.match(spec):
        raise ValueError(f"--method must be package.module:Class, got {spec!r}")
    module_name, _, qualname = spec.partition(":")
    try:
        obj = import_user_module(module_name)
    except UserModuleError as err:
        raise ValueError(f"--method {spec}: {err}") from err
    for part in qualname.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"--method {spec}: {module_name} has no {qualname!r}")
        obj = getattr(obj, part)
    if not inspect.isclass(obj):
        raise ValueError(f"--method {spec}: {qualname!r} is a {type(obj).__name__}, not a class")
    missing = [m for m in required if not callable(getattr(obj, m, None))]
    if missing:
        raise ValueError(
            f"--method {spec}: the class has no {', '.join(missing)} method "
            f"(needs {', '.join(required)})"
        )
    return obj


def _init_parameters(cls) -> set[str] | None:
    """Return the keyword parameters of ``cls.__init__``.

    None when it takes ``**kwargs`` or has no readable signature (then any parameter is
    passed on and the class judges it).
    """
    try:
        params = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):
        return None
    if any(p.kind is p.VAR_KEYWORD for p in params):
        return None
    return {p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
