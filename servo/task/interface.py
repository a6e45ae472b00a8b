"""What a policy under evaluation is, and what it is given.

A policy is any object with ``reset(target)`` and ``act(observation) -> (v, omega)``
([`Policy`][servo.task.interface.Policy], the shape of Habitat-Lab's ``Agent``); it is made by a
factory ``factory(servo_map, rng, **params)``
([`PolicyFactory`][servo.task.interface.PolicyFactory]) named on the command line as
``package.module:factory``. The truth boundary (docs/decisions/064-truth-boundary.md): a policy is
given the target as a stored view ([`Target`][servo.task.interface.Target]: its index and image, no
pose), the env's observations (camera, laser, odometry relative to the episode's start), the map as
sensed recordings only ([`sensed_map`][servo.task.interface.sensed_map]: the true poses and manifold
labels of its views blanked) and a seeded ``numpy.random.Generator``. Only the oracle, by name,
reads the truth.
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from common.user_modules import UserModuleError, import_user_module
from scenes import NO_MANIFOLD
from servo.maps import ServoMap


class PolicyLoadError(ValueError):
    """A policy spec that names no importable factory, or a factory that gives no policy."""


@dataclass(frozen=True)
class Target:
    """What a policy may know of its target: a stored view of the map, by index and image.

    ``operator.index(target)`` is the view's index, so a policy written for an integer target
    (``servo_map.check_view(target)``) takes a ``Target`` as it is.

    Parameters
    ----------
    view : int
        The target's stored-view index in the map the policy was given.
    image : ndarray of shape (H, W, 3), uint8
        The stored view's image (read-only).

    Attributes
    ----------
    view, image
        The parameters (the object is frozen).

    Examples
    --------
    >>> import operator
    >>> import numpy as np
    >>> from servo.task import Target
    >>> target = Target(3, np.zeros((2, 2, 3), np.uint8))
    >>> operator.index(target), target.image.flags.writeable
    (3, False)

    See Also
    --------
    servo.task.Policy : The interface a policy under evaluation has.
    """

    view: int
    image: np.ndarray

    def __post_init__(self):
        """Check the view and store a read-only copy of the image."""
        if isinstance(self.view, bool) or not isinstance(self.view, int | np.integer):
            raise TypeError(f"view must be an integer, got {self.view!r}")
        image = np.array(self.image, dtype=np.uint8)  # a copy: the map's array stays untouched
        image.flags.writeable = False
        object.__setattr__(self, "view", int(self.view))
        object.__setattr__(self, "image", image)

    def __index__(self) -> int:
        """Return the view's index."""
        return self.view


@runtime_checkable
class Policy(Protocol):
    """The interface of a policy under evaluation.

    [`servo.task.run_episode`][servo.task.evaluation.run_episode] calls it.

    ``reset(target)`` starts an episode toward ``target`` (a
    [`Target`][servo.task.interface.Target]); ``act(observation)`` gives the command for one step
    from the env's observation dict (``image``, ``scan``, ``scan_valid``, ``odometry`` relative to
    the episode's start, ``target_image``, ``target_scan``, ``target_scan_valid``): ``(v, omega)``
    in m/s and rad/s, finite, inside the env's action space ``[-0.5, 1.5] x [-1.5, 1.5]``.

    An interface: a policy's own constructor (called by its factory) takes what it needs.

    Attributes
    ----------
    waypoint_ : int, optional
        The stored view the policy is heading for, if it has one: the runner then records F
        toward it along the trajectory.

    Examples
    --------
    >>> import numpy as np
    >>> from servo.task import Policy
    >>> class Spin:
    ...     def reset(self, target):
    ...         pass
    ...     def act(self, observation):
    ...         return np.array([0.0, 1.0], np.float32)
    >>> isinstance(Spin(), Policy)
    True

    See Also
    --------
    servo.task.PolicyFactory : How a policy is made.
    servo.task.Target : What it is given of the target.
    """

    def reset(self, target: Target) -> None:
        """Start an episode toward ``target``.

        Parameters
        ----------
        target : Target
            The target's stored view.
        """

    def act(self, observation: dict) -> np.ndarray:
        """Return the command ``(v, omega)`` for this observation.

        Parameters
        ----------
        observation : dict
            The env's observation.

        Returns
        -------
        ndarray of shape (2,)
            The command, m/s and rad/s.
        """


class PolicyFactory(Protocol):
    """``factory(servo_map, rng, **params) -> Policy``: a policy for one world's map.

    ``servo_map`` is the world's [`ServoMap`][servo.maps.types.ServoMap] as sensed
    ([`sensed_map`][servo.task.interface.sensed_map]: images, features, scans, scan-matched
    odometry, the clusters learned without labels, the view graph; its ``true_poses`` are NaN and
    its ``true_labels`` ``NO_MANIFOLD``); ``rng`` a seeded ``numpy.random.Generator``, the policy's
    only source of randomness; ``params`` the ``--policy-arg`` values. A factory refuses unknown
    params (Python does for named keyword arguments).

    A callable; a module-level function is the usual form.

    Examples
    --------
    >>> import numpy as np
    >>> from servo.task import Policy, PolicyFactory
    >>> def make_policy(servo_map, rng, speed=0.5):
    ...     class Forward:
    ...         def reset(self, target):
    ...             pass
    ...         def act(self, observation):
    ...             return np.array([speed, 0.0], np.float32)
    ...     return Forward()
    >>> factory: PolicyFactory = make_policy
    >>> isinstance(factory(None, np.random.default_rng(0), speed=0.3), Policy)
    True

    See Also
    --------
    servo.task.load_factory : Imports the factory a ``package.module:factory`` spec names.
    servo.task.sensed_map : The map it is given.
    """

    def __call__(self, servo_map: ServoMap, rng: np.random.Generator, **params) -> Policy:
        """Make a policy for ``servo_map``.

        Parameters
        ----------
        servo_map : ServoMap
            The world's map as sensed.
        rng : numpy.random.Generator
            The policy's generator, set anew at every episode.
        **params
            The policy's settings.

        Returns
        -------
        Policy
            The policy.
        """


def sensed_map(m: ServoMap) -> ServoMap:
    """Return ``m`` as a policy may see it.

    Its evaluation-only fields are blanked (``true_poses`` NaN, ``true_labels``
    ``NO_MANIFOLD``, no ``manifold_names`` and no ``world_digest``: a generated world's
    manifold names would tell its layout), it holds no key to the files it was built from
    (`neutral_names`), and its arrays are read-only views, so that a policy can neither read
    the truth nor change the map the env scores with.

    Parameters
    ----------
    m : ServoMap
        The map.

    Returns
    -------
    ServoMap
        The sensed map.
    """
    fields = {}
    for f in dataclasses.fields(m):
        value = getattr(m, f.name)
        if isinstance(value, np.ndarray):
            value = value.view()
            value.flags.writeable = False
        fields[f.name] = value
    poses = np.full(m.true_poses.shape, np.nan)
    labels = np.full(m.true_labels.shape, NO_MANIFOLD, m.true_labels.dtype)
    poses.flags.writeable = labels.flags.writeable = False
    blank = {"true_poses": poses, "true_labels": labels, "manifold_names": (), "world_digest": None}
    return ServoMap(**{**fields, **blank, **neutral_names(m)})


def neutral_names(m: ServoMap) -> dict:
    """Return the fields of ``m`` that would lead to the files it was built from, made neutral.

    ``sequence_names`` ``recording-0``, ``recording-1``, ... (a recording's name is its true
    branch), ``frame`` each view's place in its recording (0, 1, 2, ...; not the index of a
    frame in the dataset) and ``key`` a digest of the stored features (the cache key names
    the map's file in the data home). Read-only arrays.

    Parameters
    ----------
    m : ServoMap
        The map.

    Returns
    -------
    dict
        The neutral ``sequence_names``, ``frame`` and ``key``.
    """
    frame = np.zeros(len(m.sequence), np.int64)
    for s in np.unique(m.sequence):
        at = np.flatnonzero(m.sequence == s)
        frame[at[np.argsort(m.frame[at], kind="stable")]] = np.arange(len(at))
    frame.flags.writeable = False
    features = np.ascontiguousarray(m.features)
    key = hashlib.sha256(b"sensed-map" + features.tobytes()).hexdigest()[:16]
    names = [f"recording-{i}" for i in range(len(m.sequence_names))]
    return {"sequence_names": names, "frame": frame, "key": key}


def reseed(rng: np.random.Generator, episode_seed: int, policy_seed: int = 0) -> None:
    """Set ``rng`` to the state of episode ``episode_seed`` and run seed ``policy_seed``.

    ``rng`` is the generator a factory was given, set in place: an outside policy's draws then
    depend on the episode only, not on which worker ran which episodes before it.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator to set.
    episode_seed : int
        The episode's seed.
    policy_seed : int, default 0
        The run's policy seed.
    """
    seq = np.random.SeedSequence(int(episode_seed), spawn_key=(2, int(policy_seed)))
    rng.bit_generator.state = type(rng.bit_generator)(seq).state


def is_policy_spec(name: str) -> bool:
    """Tell whether ``name`` names an outside factory (``package.module:factory``).

    Parameters
    ----------
    name : str
        A policy name.

    Returns
    -------
    bool
        True for a string holding ``:``.
    """
    return isinstance(name, str) and ":" in name


def load_factory(spec: str):
    """Import the factory ``spec`` names (``package.module:factory``).

    It is imported as ``python -m`` would: the module's code runs, with the current directory
    first on ``sys.path``.

    Raises [`PolicyLoadError`][servo.task.interface.PolicyLoadError] naming the spec when it is
    malformed, does not import or names nothing callable.

    Parameters
    ----------
    spec : str
        ``package.module:factory``.

    Returns
    -------
    callable
        The factory.
    """
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise PolicyLoadError(
            f"policy must be a built-in name or package.module:factory, got {spec!r}"
        )
    module_name, attr = spec.split(":")
    if not module_name or not attr.isidentifier():
        raise PolicyLoadError(f"policy must be package.module:factory, got {spec!r}")
    try:
        module = import_user_module(module_name)
    except UserModuleError as err:
        raise PolicyLoadError(f"policy {spec!r}: {err}") from err
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise PolicyLoadError(f"policy {spec!r}: {module_name} has no callable {attr!r}")
    return factory


def make_outside_policy(spec: str, servo_map: ServoMap, rng: np.random.Generator, **params):
    """Return the policy the factory ``spec`` makes from the sensed ``servo_map``.

    Raises [`PolicyLoadError`][servo.task.interface.PolicyLoadError] when the factory cannot be
    loaded, raises, or gives an object without ``reset`` and ``act``.

    Parameters
    ----------
    spec : str
        The factory, ``package.module:factory``.
    servo_map : ServoMap
        The map; the factory is given it as sensed.
    rng : numpy.random.Generator
        The policy's generator.
    **params
        The factory's keyword arguments.

    Returns
    -------
    Policy
        The policy.
    """
    factory = load_factory(spec)
    try:
        policy = factory(sensed_map(servo_map), rng, **params)
    except Exception as err:
        raise PolicyLoadError(
            f"policy {spec!r}: the factory raised {type(err).__name__}: {err}"
        ) from err
    if not isinstance(policy, Policy):
        raise PolicyLoadError(
            f"policy {spec!r}: the factory gave a {type(policy).__name__}, which lacks "
            f"reset(target) and act(observation)"
        )
    return policy
