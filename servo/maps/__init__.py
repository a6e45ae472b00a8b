"""The map a robot servoes on: its recordings' views, clustered and linked.

The views are clustered into manifolds by
[`ManifoldClustering`][mapping.manifold.clustering.ManifoldClustering] and linked across recordings
by ICP of their scans (``build``), its types (``types``), its file (``file``: untrusted on load,
written atomically), the laser-profile distances between a scan and the stored views
(``scan_profile``) and what a map needs from a dataset (``needs``: beams, stored views).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "build_map": "servo.maps.build",
        "load_or_build": "servo.maps.build",
        "map_key": "servo.maps.build",
        "FORMAT_VERSION": "servo.maps.file",
        "load_map": "servo.maps.file",
        "map_paths": "servo.maps.file",
        "save_map": "servo.maps.file",
        "clip_ranges": "servo.maps.scan_profile",
        "profile_distances": "servo.maps.scan_profile",
        "MapError": "servo.maps.types",
        "MapSettings": "servo.maps.types",
        "ServoMap": "servo.maps.types",
    },
)
