"""The colour bound: one row per appearance mode and classifier, one error per fresh seed."""

import pytest

from experiments.manifold.colour_bound import draw_modes, evaluate, format_report
from scripts.manifold.protocol import dataset_dir


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    from sim.camera import CameraConfig
    from sim.collect import CollectionSettings, collect_dataset

    root = tmp_path_factory.mktemp("colour")
    for seed, mode in ((0, "hard"), (1, "hard"), (2, "hard"), (0, "default")):
        settings = CollectionSettings(
            worlds=("lawn",), frames=6, seed=seed, appearance=mode, camera=CameraConfig(32, 24)
        )
        condition = "hard" if mode == "hard" else "interleaved"
        collect_dataset(dataset_dir(root, seed, condition), settings, jobs=1, progress=False)
    return root


def test_the_bound_trains_on_the_dev_seed_and_scores_each_fresh_seed(root):
    result = evaluate(root, [1, 2], modes=("hard",))
    assert [r["appearance"] for r in result["rows"]] == ["hard", "hard"]
    for r in result["rows"]:
        assert len(r["errors"]) == 2 and all(0.0 <= e <= 1.0 for e in r["errors"])
        assert r["summary"]["lo"] <= r["summary"]["mean"] <= r["summary"]["hi"]
    assert format_report(result).count("| hard |") == 2
    # a hard dataset in a default dataset's folder is refused, not scored as default
    dataset_dir(root, 1, "hard").rename(dataset_dir(root, 1, "interleaved"))
    try:
        with pytest.raises(ValueError, match="m-data-1: condition 'interleaved' needs"):
            evaluate(root, [1], modes=("default",))
    finally:
        dataset_dir(root, 1, "interleaved").rename(dataset_dir(root, 1, "hard"))


@pytest.mark.parametrize(
    ("seeds", "modes", "match"),
    [([0, 1], ("hard",), "fresh seeds"), ([], ("hard",), "fresh seeds"), ([1], ("dim",), "modes")],
)
def test_bad_arguments_are_refused(root, seeds, modes, match):
    with pytest.raises(ValueError, match=match):
        evaluate(root, seeds, modes=modes)


def test_the_figure_has_a_row_per_mode_and_a_tile_per_manifold(root, tmp_path):
    import cv2

    img = cv2.imread(str(draw_modes(root, tmp_path / "modes.png")))
    assert img.shape == (2 * 120, 4 * 160, 3)  # default and hard; the lawn's 4 manifolds
    assert (img[:120] != img[120:]).any()  # the modes look different from the same poses
