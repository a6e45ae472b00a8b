"""The names users import from the package faces: every one still imports, and a function is
never replaced by the module of the same name."""

import importlib

import pytest

import mapping
import scenes
import servo

MAPPING = (
    "ColorHistogramFeatures",
    "EigengapNCutClustering",
    "ImageFeatures",
    "KNNSpectralClustering",
    "ManifoldClustering",
    "NormalizedCutClustering",
    "NotFittedError",
    "ObservationGraphPartitioner",
    "ScanFeatures",
    "ScanStatistics",
    "SelfTuningSpectralClustering",
    "SplitNode",
    "TopologicalMap",
    "adjusted_rand_index",
    "best_sigma_ncut",
    "clustering_error",
    "icp",
    "ncut",
    "purity",
    "recursive_ncut_partition",
    "refine_poses",
    "scan_to_points",
    "sensed_space_overlap",
    "spectral_bisection",
)
SERVO = (
    "ManifoldServo",
    "MapError",
    "MapSettings",
    "Protocol",
    "ServoEnv",
    "ServoMap",
    "SignalServo",
    "SignalServoConfig",
    "build_map",
    "evaluate",
    "load_or_build",
    "run_protocol",
)
SCENES = (
    "MANIFOLDS",
    "MANIFOLD_IDS",
    "NO_MANIFOLD",
    "RANDOMIZATION",
    "WORLDS",
    "World",
    "build_world",
)


@pytest.mark.parametrize(
    ("package", "names"), [(mapping, MAPPING), (servo, SERVO), (scenes, SCENES)]
)
def test_every_public_name_imports_from_its_package(package, names):
    assert set(names) <= set(package.__all__)
    for name in names:
        exec(f"from {package.__name__} import {name}", {})  # raises if it does not import


def test_the_faces_give_the_defining_modules_objects():
    from mapping.grouping.normalized_cut import ncut
    from mapping.scan_matching.icp_alignment import icp

    importlib.import_module("mapping.scan_matching.icp_alignment")
    assert mapping.icp is icp and mapping.ncut is ncut  # functions, never the modules
    assert servo.evaluate is importlib.import_module("servo.task.evaluation")
