"""Self-describing result files: every evaluation's numbers with what produced them.

A result file is one JSON object (``FORMAT``, ``FORMAT_VERSION``; see
``docs/decisions/070-result-files-and-protocol-versions.md``)::

    {"format": "topomap-result", "format_version": 1,
     "task": "manifold-clustering", "protocol": {"name": ..., "version": 1},
     "split": "test", "metric": {"name": "test_error", "kind": "error"},
     "method": {"name": ..., "spec": "package.module:Class", "params": {...}, "notes": ...},
     "code_version": {"package": "0.2.0", "commit": "9863b14"},
     "machine": {"cores": 2, "platform": "Linux-...-x86_64", "python": "3.11.9"},
     "records": [{"group": "interleaved/hsv", "unit": "seed 3", "value": 0.03,
                  "failure": null, ...}, ...],
     ...}

A record is one independent unit (a dataset seed, a world, a log, an episode) of one group
(the condition the leaderboard ranks within); ``value`` is the metric (a number of size at
most ``MAX_VALUE``, or a bool for a ``rate``), ``failure`` the reason the method gave no value
(None when it did); every record has both keys. Other top-level keys are the evaluation's own
(``servo-eval`` keeps its ``results`` there).

The reader treats a file as untrusted: it is refused before parsing when larger than
``MAX_BYTES``, never unpickled, and every field is checked;
[`ResultFileError`][scripts.leaderboard.files.ResultFileError] names the file and the field.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import subprocess
from pathlib import Path

from common.fileio import UnreadableJSON, read_json, write_json

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "KINDS",
    "MAX_BYTES",
    "MAX_VALUE",
    "ResultFileError",
    "code_version",
    "envelope",
    "file_tag",
    "machine",
    "read_result",
    "write_result",
]

FORMAT = "topomap-result"
FORMAT_VERSION = 1
MAX_BYTES = 64 << 20  # a servo file of 1000 episodes is ~5 MB
MAX_RECORDS = 100_000
# the largest |value| of a record: no metric of the testbed comes near it (errors and rates
# are fractions), and beyond it a mean or a percentage loses its digits or overflows to inf
MAX_VALUE = 1e12
MAX_VERSION = 1_000_000  # the largest protocol version
# metric kind -> whether higher is better; "rate" values are bools (Wilson interval)
KINDS = {"error": False, "score": True, "rate": True}
_ROOT = Path(__file__).resolve().parents[2]


class ResultFileError(ValueError):
    """A result file that cannot be used; the message names the file and the field.

    Parameters
    ----------
    path : str or os.PathLike
        The result file.
    field : str
        The field that is wrong (``"file"`` for the file as a whole).
    problem : str
        What is wrong with it.
    """

    def __init__(self, path, field: str, problem: str):
        self.path, self.field = Path(path), field
        super().__init__(f"{path}: {field}: {problem}")


def code_version() -> dict:
    """Return the package version and, in a git checkout, the commit.

    The commit has ``+dirty`` appended when the tree has uncommitted changes.

    Returns
    -------
    dict
        ``{"package": str or None, "commit": str or None}``; ``commit`` is None outside a
        checkout, ``package`` None where the package is not installed.
    """
    from importlib import metadata

    try:
        package = metadata.version("topomap-testbed")
    except metadata.PackageNotFoundError:
        package = None
    try:
        commit = subprocess.run(
            ["git", "-C", str(_ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
        dirty = subprocess.run(
            ["git", "-C", str(_ROOT), "status", "--porcelain", "-uno"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
        sha = commit.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        sha = None
    return {"package": package, "commit": sha}


def machine() -> dict:
    """Return the cores, platform and Python of this machine (what the timings ran on).

    Returns
    -------
    dict
        ``cores``, ``platform``, ``processor`` and ``python``.
    """
    return {
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "processor": platform.machine(),
        "python": platform.python_version(),
    }


def envelope(
    task: str,
    protocol: tuple[str, int],
    split: str,
    method: dict,
    metric: tuple[str, str],
    records: list[dict],
    **extra,
) -> dict:
    """Build a result file's object; the code version and machine are added here.

    Parameters
    ----------
    task : str
        The task evaluated.
    protocol : tuple of (str, int)
        The protocol's name and version.
    split : str
        The split evaluated on.
    method : dict
        ``name``, ``spec``, ``params`` and optional ``notes``.
    metric : tuple of (str, str)
        The metric's name and kind, one of ``KINDS``.
    records : list of dict
        The records, each with ``group``, ``unit``, ``value`` and ``failure``.
    **extra
        The evaluation's own top-level keys.

    Returns
    -------
    dict
        The result file's object.

    Raises
    ------
    ValueError
        When the metric kind is not one of ``KINDS``, or an ``extra`` key would replace one
        of the envelope's own.
    """
    name, kind = metric
    if kind not in KINDS:
        raise ValueError(f"metric kind must be one of {tuple(KINDS)}, got {kind!r}")
    clash = set(extra) & set(_REQUIRED)
    if clash:
        raise ValueError(f"extra keys {sorted(clash)} would replace the envelope's own")
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "task": task,
        "protocol": {"name": protocol[0], "version": int(protocol[1])},
        "split": split,
        "metric": {"name": name, "kind": kind},
        "method": method,
        "code_version": code_version(),
        "machine": machine(),
        "records": records,
        **extra,
    }


def write_result(path: str | os.PathLike, result: dict) -> Path:
    """Write ``result`` to ``path`` atomically, after checking it as the reader will.

    A writer must not produce a file its own reader refuses. A file there of another method
    (its ``spec`` or ``params`` differ) is not replaced:
    [`ResultFileError`][scripts.leaderboard.files.ResultFileError] names both.

    Parameters
    ----------
    path : str or os.PathLike
        Where to write.
    result : dict
        An [`envelope`][scripts.leaderboard.files.envelope].

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    check_result(result, path)
    if path.exists():
        try:
            old = read_result(path)["method"]
        except ResultFileError:
            old = None  # not a result file of this format: replaced as before
        new = result["method"]
        if old is not None and _identity(old) != _identity(new):
            raise ResultFileError(
                path,
                "method",
                (
                    f"holds the results of {_identity(old)[0]} with params {_identity(old)[1]}; "
                    f"refusing to replace them with those of {_identity(new)[0]} with params "
                    f"{_identity(new)[1]}: write to another folder"
                ),
            )
    write_json(path, result)
    return path


def _identity(method: dict) -> tuple[str, str]:
    spec = method.get("spec") or method.get("name")
    return str(spec), json.dumps(method.get("params", {}), sort_keys=True, default=str)


def file_tag(spec: str, params: dict | None) -> str:
    """Return a file-name part for a method: its spec and a digest of its params.

    The full spec has ``:`` as ``.`` and anything but letters, digits and ``._-`` as ``_``;
    with params, the first 8 hex digits of their SHA-256 follow, so that two methods of one
    class name, or one method with other params, never share a file.
    ``file_tag("sklearn.cluster:KMeans", {"n_init": 3})`` starts ``sklearn.cluster.KMeans-``.

    Parameters
    ----------
    spec : str
        The method's ``package.module:Class``.
    params : dict or None
        The method's parameters.

    Returns
    -------
    str
        The tag (the spec part cut to 120 characters).
    """
    tag = re.sub(r"[^A-Za-z0-9._-]+", "_", str(spec).replace(":", "."))[:120]
    if params:
        blob = json.dumps(params, sort_keys=True, default=str).encode()
        tag += "-" + hashlib.sha256(blob).hexdigest()[:8]
    return tag


def read_result(path: str | os.PathLike) -> dict:
    """Read and check the result file at ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The result file.

    Returns
    -------
    dict
        The checked result file.

    Raises
    ------
    ResultFileError
        Naming the file and the field when it is no regular file, too large, not JSON, or a
        field is missing or malformed.
    """
    path = Path(path)
    if not path.is_file():  # a named pipe would block the read, a device never end it
        raise ResultFileError(
            path, "file", "not a regular file (a folder, a named pipe, a device, or nothing)"
        )
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise ResultFileError(path, "file", f"{size} bytes, more than the {MAX_BYTES} allowed")
    try:
        data = read_json(path)
    except UnreadableJSON as err:
        raise ResultFileError(path, "file", f"not JSON ({err})") from None
    return check_result(data, path)


_REQUIRED = (
    "format",
    "format_version",
    "task",
    "protocol",
    "split",
    "metric",
    "method",
    "code_version",
    "machine",
    "records",
)


def check_result(data, path) -> dict:
    """Check that ``data`` is a well-formed result of this format version.

    Parameters
    ----------
    data : object
        A result file's content as parsed.
    path : str or os.PathLike
        The file it came from, named in the error.

    Returns
    -------
    dict
        ``data``.

    Raises
    ------
    ResultFileError
        For ``path`` when ``data`` is not well-formed.
    """

    def fail(field, problem):
        raise ResultFileError(path, field, problem)

    if not isinstance(data, dict):
        fail("file", f"expected a JSON object, got {type(data).__name__}")
    for key in _REQUIRED:
        if key not in data:
            fail(key, "missing")
    if data["format"] != FORMAT:
        fail("format", f"expected {FORMAT!r}, got {data['format']!r}")
    if data["format_version"] != FORMAT_VERSION or isinstance(data["format_version"], bool):
        fail(
            "format_version",
            f"this reader reads version {FORMAT_VERSION}, got {data['format_version']!r}",
        )
    for key in ("task", "split"):
        if not _short_str(data[key]):
            fail(key, f"expected a non-empty string, got {data[key]!r}")
    p = data["protocol"]
    if not (isinstance(p, dict) and _short_str(p.get("name")) and _int(p.get("version"))):
        fail(
            "protocol",
            f"expected {{'name': str, 'version': int in [0, {MAX_VERSION}]}}, got {_shown(p)}",
        )
    m = data["metric"]
    if not (
        isinstance(m, dict)
        and _short_str(m.get("name"))
        and _short_str(m.get("kind"))
        and m["kind"] in KINDS
    ):
        fail("metric", f"expected {{'name': str, 'kind': one of {tuple(KINDS)}}}, got {_shown(m)}")
    method = data["method"]
    if not (isinstance(method, dict) and _short_str(method.get("name"))):
        fail("method", f"expected an object with a 'name', got {_shown(method)}")
    if not isinstance(method.get("params", {}), dict):
        fail("method.params", "expected an object")
    notes = method.get("notes")
    if notes is not None and not isinstance(notes, str):
        fail("method.notes", f"expected a string or null, got {_shown(notes)}")
    for key in ("code_version", "machine"):
        if not isinstance(data[key], dict):
            fail(key, "expected an object")
    records = data["records"]
    if not isinstance(records, list) or len(records) > MAX_RECORDS:
        fail("records", f"expected a list of at most {MAX_RECORDS} records")
    rate = m["kind"] == "rate"
    seen = set()
    for i, r in enumerate(records):
        where = f"records[{i}]"
        if not isinstance(r, dict):
            fail(where, "expected an object")
        if not (_short_str(r.get("group")) and _short_str(r.get("unit"))):
            fail(where, "'group' and 'unit' must be non-empty strings")
        if (r["group"], r["unit"]) in seen:
            fail(where, f"unit {r['unit']!r} appears twice in group {r['group']!r}")
        seen.add((r["group"], r["unit"]))
        for key in ("value", "failure"):
            if key not in r:
                fail(
                    f"{where}.{key}",
                    "missing (every record has 'value' and 'failure', null when it does not apply)",
                )
        failure, value = r["failure"], r["value"]
        if failure is not None:
            if not isinstance(failure, str) or value is not None:
                fail(where, "a failed record has a 'failure' string and 'value' null")
        elif rate and not isinstance(value, bool):
            fail(f"{where}.value", f"a rate's record is true or false, got {_shown(value)}")
        elif not rate and not _finite(value):
            fail(
                f"{where}.value",
                f"expected a finite number of size at most {MAX_VALUE:g}, got {_shown(value)}",
            )
    return data


def _shown(value, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters: a 400-digit integer stays readable."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."


def _short_str(value, limit: int = 500) -> bool:
    return isinstance(value, str) and 0 < len(value) <= limit


def _int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= MAX_VERSION


def _finite(value) -> bool:
    """Check for a number within ``MAX_VALUE``.

    NaN is not: it compares false; an int of 400 digits is compared exactly, where
    ``math.isfinite`` would raise OverflowError.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    return abs(value) <= MAX_VALUE
