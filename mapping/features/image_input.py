"""Input checks both image transformers share.

Sizes and grids as pairs of positive ints, and the scikit-learn tags that say their input is
a batch of images.
"""

from __future__ import annotations

import numpy as np

__all__ = ["image_transformer_tags", "positive_pair"]


def positive_pair(value: object, name: str, what: str) -> tuple[int, int]:
    """Return ``value`` as a pair of positive ints (an image size, a grid), or raise a clear error.

    Only integers: a string ("32" is not (3, 2)) or a float (8.7 is not 8) is refused rather
    than read digit by digit or truncated.

    Parameters
    ----------
    value : object
        The pair to check.
    name : str
        Parameter name, for the error message.
    what : str
        What the pair is (e.g. "a (width, height) pair"), for the error message.

    Returns
    -------
    tuple of (int, int)
        The two values.

    Raises
    ------
    ValueError
        When ``value`` is not two positive ints.
    """
    pair = None if isinstance(value, str | bytes) else np.asarray(value, dtype=object)
    if (
        pair is None
        or pair.shape != (2,)
        or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in pair)
        or min(pair) < 1
    ):
        raise ValueError(f"{name} must be {what} of positive ints, got {value!r}")
    return int(pair[0]), int(pair[1])


def image_transformer_tags(tags):
    """Return the tags of the image transformers: their input is a batch of images, not a table.

    scikit-learn's estimator checks only feed 2-D tables, so they cannot apply (they skip an
    estimator without ``two_d_array``, as for its own ``PatchExtractor``); the API checks that
    need no data, and image versions of the others, are in tests/mapping/test_sklearn_checks.py.

    Parameters
    ----------
    tags : sklearn.utils.Tags
        The estimator's tags from its base classes; changed in place.

    Returns
    -------
    sklearn.utils.Tags
        ``tags``, marked as taking 3-D input and no 2-D table.
    """
    tags.input_tags.two_d_array = False
    tags.input_tags.three_d_array = True
    return tags
