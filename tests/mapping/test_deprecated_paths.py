"""The old import paths of moved modules still give the same objects for one release, each with
a ``DeprecationWarning`` naming where to import from now."""

import importlib

import pytest

# (old module, name, new module)
MOVED = [
    ("mapping.similarity", "default_n_neighbors", "mapping.grouping"),
    ("mapping.similarity", "knn_gaussian_affinity", "mapping.grouping"),
    ("mapping.runs", "run_starts_from_groups", "mapping.run_starts"),
    ("mapping.icp_solver", "icp", "mapping.scan_matching"),
    ("mapping.icp_solver", "icp_batch", "mapping.scan_matching"),
    ("mapping.icp_solver", "densify_scan", "mapping.scan_matching"),
    ("mapping.icp_solver", "IcpResult", "mapping.scan_matching.icp_alignment"),
    ("mapping.icp_solver", "IcpBatchResult", "mapping.scan_matching.icp_alignment"),
    *(
        ("mapping.synthetic", name, "mapping.manifold")
        for name in (
            "SYNTHETIC_SETS",
            "branching_sequences",
            "converging_paths",
            "lines_variable_spacing",
            "make_all",
            "parallel_lines",
            "plot_sets",
            "spirals_3d",
        )
    ),
    *(
        ("mapping.synthetic_scans", name, "mapping.grouping")
        for name in ("office_path", "office_world", "raycast", "simulate_odometry")
    ),
    ("mapping.synthetic_scans", "OfficeWorld", "mapping.grouping.synthetic_scans"),
]


@pytest.mark.parametrize(("old", "name", "new"), MOVED)
def test_an_old_path_gives_the_same_object_and_names_the_new_one(old, name, new):
    with pytest.warns(DeprecationWarning, match=rf"import {name} from {new}\b"):
        value = getattr(importlib.import_module(old), name)
    assert value is getattr(importlib.import_module(new), name)


@pytest.mark.parametrize(("old", "name", "new"), MOVED)
def test_from_import_of_an_old_path_warns(old, name, new):
    with pytest.warns(DeprecationWarning, match=new.replace(".", r"\.")):
        exec(f"from {old} import {name}", {})


def test_an_old_path_lists_its_names_and_refuses_others():
    module = importlib.import_module("mapping.similarity")
    assert {"default_n_neighbors", "knn_gaussian_affinity"} <= set(dir(module))
    with pytest.raises(AttributeError, match="no_such_name"):
        module.no_such_name  # noqa: B018
