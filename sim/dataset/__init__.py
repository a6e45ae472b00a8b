"""The on-disk dataset: one ``.npz`` per sequence and a ``meta.json``, loaded without pickle.

Layout of a dataset directory (schema version `SCHEMA_VERSION`)::

    meta.json            settings (world, seed, sensors, teleop), the manifold names, and per
                         sequence its file, world, frame count and SHA-256
    hallway-left.npz     one file per sequence, arrays indexed by frame:
        images    uint8   (N, H, W, 3)  RGB camera frames
        depth     float32 (N, H, W)     metric depth (only when collected with depth)
        scans     float32 (N, B)        laser ranges, +inf = no return within max range
        angles    float32 (B,)          beam angles in the sensor frame (rad, CCW, 0 = ahead)
        poses     float64 (N, 3)        true pose (x, y, yaw) in the world frame (*)
        odometry  float64 (N, 3)        odometry pose (starts at the true start pose)
        commands  float64 (N, 2)        command (v m/s, omega rad/s) being executed
        labels    int16   (N,)          ground-truth manifold id (index into meta "manifolds"),
                                        -1 if on no manifold (*)
        times     float64 (N,)          simulation time (s)

(*) ground truth: present when ``meta["ground_truth"]`` is true (collected in simulation); a
dataset imported from a robot's log (`sim.readers.rosbag`) has ``"ground_truth": false``,
no ``poses`` or ``labels`` arrays and no manifolds. A dataset of a robot without a camera (a
laser-only bag) has ``"camera": false`` and no ``images`` arrays, one without a laser (a
camera-only bag) ``"laser": false`` and no ``scans`` or ``angles`` arrays (both keys absent:
true); a method that needs the missing sensor raises
[`MissingSensorError`][sim.dataset.schema.MissingSensorError]. Schema version 1 (before
``"ground_truth"`` existed) is still read, as a dataset with ground truth.

Reading checks the values too, against `common.bounds`: finite poses, odometry, commands,
times and angles within their bounds, times that never go backwards, ranges and depths that are
never NaN or negative (``+inf``: no return), labels within the manifolds (a dataset with labels
must list its ``manifolds``), images and scans that are not empty, a maximum range within the
bound of every reader. Across the sequences (`sim.dataset.consistency`): one beam layout,
one image size, and both as the settings record them, worlds among the settings' worlds, and
no file listed under two sequence names. Anything else raises
[`DatasetError`][sim.dataset.schema.DatasetError] naming the file (or the folder) and the array.

Every file is written to a temporary name and renamed, and ``meta.json`` lists a sequence only
after its file is complete, so an interrupted collection never leaves a half-written sequence.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        **dict.fromkeys(
            [
                "ARRAYS",
                "FORMAT_NAME",
                "GROUND_TRUTH",
                "META_FILE",
                "PER_FRAME",
                "READABLE_VERSIONS",
                "SCHEMA_VERSION",
                "SHAPES",
                "DatasetError",
                "MissingSensorError",
                "SENSORS",
                "check_entry",
                "read_meta",
            ],
            "sim.dataset.schema",
        ),
        "Dataset": "sim.dataset.model",
        "Sequence": "sim.dataset.model",
        **dict.fromkeys(
            ["file_sha256", "load_dataset", "load_sequence", "read_npz", "write_sequence"],
            "sim.dataset.loading",
        ),
    },
)
