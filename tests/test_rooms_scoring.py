"""The IPA room-segmentation scores of ``bench/rooms_scoring.py`` on hand-computed cases."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))

from rooms_scoring import (  # noqa: E402
    MIN_REGION_PX,
    ground_truth_rooms,
    read_ground_truth,
    score_rooms,
)


def two_rooms() -> np.ndarray:
    """Ground truth: room 1 of 20 x 20 = 400 px and room 2 of 20 x 10 = 200 px, with a
    one-pixel wall column between them (label 0)."""
    truth = np.zeros((20, 31), np.int32)
    truth[:, :20] = 1
    truth[:, 21:] = 2
    return truth


def test_a_perfect_segmentation_scores_one_whatever_its_ids():
    truth = two_rooms()
    predicted = np.where(truth == 1, 7, np.where(truth == 2, 3, 0))
    s = score_rooms(predicted, truth)
    assert (s.recall, s.precision, s.mean_iou, s.segments_per_room) == (1.0, 1.0, 1.0, 1.0)
    assert (s.n_rooms, s.n_segments) == (2, 2)


def test_one_segment_over_two_rooms_loses_precision_not_recall():
    truth = two_rooms()
    predicted = np.ones_like(truth)  # 620 px: both rooms and the wall between them
    s = score_rooms(predicted, truth)
    assert s.precision == pytest.approx(400 / 620)
    assert s.recall == pytest.approx(1.0)  # (400/400 + 200/200) / 2
    assert s.mean_iou == pytest.approx((400 / 620 + 200 / 620) / 2)
    assert s.segments_per_room == 0.5


def test_a_room_split_in_two_loses_recall_not_precision():
    truth = np.ones((20, 30), np.int32)  # one room of 600 px
    predicted = np.ones_like(truth)
    predicted[:, 20:] = 2  # 400 px and 200 px
    s = score_rooms(predicted, truth)
    assert s.precision == pytest.approx(1.0)
    assert s.recall == pytest.approx(400 / 600)
    assert s.mean_iou == pytest.approx(400 / 600)
    assert s.segments_per_room == 2.0


def test_precision_and_recall_are_averages_over_regions_not_pixels():
    truth = two_rooms()
    predicted = np.zeros_like(truth)
    predicted[:, :20] = 1  # room 1 exactly
    predicted[:10, 21:] = 2  # half of room 2: 100 px, too small to count
    predicted[10:, 21:] = 3  # the other half, 100 px, too small as well
    s = score_rooms(predicted, truth)
    assert (s.n_rooms, s.n_segments) == (2, 1)
    assert s.precision == 1.0
    assert s.recall == pytest.approx((1.0 + 0.0) / 2)
    assert s.mean_iou == pytest.approx(0.5)


def test_regions_of_100_px_or_fewer_are_ignored_on_both_sides():
    truth = np.zeros((30, 30), np.int32)
    truth[:10, :10] = 1  # exactly 100 px: ignored
    truth[15:, 15:] = 2  # 225 px
    predicted = np.zeros_like(truth)
    predicted[:10, :10] = 5  # 100 px: ignored, so it cannot match room 1
    predicted[15:, 15:] = 6
    predicted[12, :] = 9  # 30 px stray segment: ignored
    s = score_rooms(predicted, truth)
    assert (s.n_rooms, s.n_segments) == (1, 1)
    assert (s.recall, s.precision) == (1.0, 1.0)
    truth[10, 0] = 1  # 101 px: now counted, and nothing covers it
    s = score_rooms(predicted, truth)
    assert s.n_rooms == 2
    assert s.recall == pytest.approx(0.5)
    assert MIN_REGION_PX == 100


def test_a_segment_outside_every_room_has_precision_zero():
    truth = np.zeros((40, 31), np.int32)
    truth[:20] = two_rooms()
    predicted = np.where(truth == 1, 1, 0)
    predicted[25:, :] = 4  # 15 x 31 = 465 px where the ground truth has no room
    s = score_rooms(predicted, truth)
    assert s.precision == pytest.approx((1.0 + 0.0) / 2)
    assert s.recall == pytest.approx((1.0 + 0.0) / 2)  # room 2 is not covered


def test_a_segment_label_need_not_be_connected():
    truth = two_rooms()
    predicted = np.where(truth > 0, 1, 0)  # one label on both rooms, wall excluded
    s = score_rooms(predicted, truth)
    assert s.n_segments == 1
    assert s.precision == pytest.approx(400 / 600)


def test_without_segments_recall_is_zero_and_precision_undefined():
    s = score_rooms(np.zeros((20, 31), np.int32), two_rooms())
    assert s.recall == 0.0 and s.mean_iou == 0.0
    assert math.isnan(s.precision)
    assert s.n_segments == 0


def test_sparse_segment_ids_are_scored_like_dense_ones():
    truth = two_rooms()
    dense = np.where(truth == 1, 1, np.where(truth == 2, 2, 0))
    sparse = np.where(truth == 1, 10_000_000, np.where(truth == 2, 2, 0))
    assert score_rooms(sparse, truth) == score_rooms(dense, truth)


def test_ground_truth_rooms_are_8_connected_pixels_brighter_than_250():
    grey = np.zeros((6, 6), np.uint8)
    grey[0:2, 0:2] = 255
    grey[2, 2] = 251  # touches the first block at a corner only: same room
    grey[4:6, 4:6] = 254
    grey[0, 5] = 250  # not brighter than 250: no room
    labels = ground_truth_rooms(grey)
    assert labels.dtype == np.int32
    assert labels[0, 0] == labels[2, 2] > 0
    assert labels[4, 4] > 0 and labels[4, 4] != labels[0, 0]
    assert labels[0, 5] == 0 and labels[3, 3] == 0
    assert len(np.unique(labels)) == 3


def test_read_ground_truth_reads_a_colour_image_as_grey(tmp_path):
    img = np.zeros((20, 31, 3), np.uint8)
    img[:, :20] = 255  # white room
    img[:, 21:] = (255, 255, 255)
    img[5, 21:] = (0, 0, 255)  # a red line splits room 2: grey 76, a wall
    path = tmp_path / "gt.png"
    cv2.imwrite(str(path), img)
    labels = read_ground_truth(path)
    assert len(np.unique(labels[labels > 0])) == 3
    assert labels[5, 25] == 0


def test_shapes_must_match():
    with pytest.raises(ValueError, match="predicted"):
        score_rooms(np.zeros((3, 4), np.int32), np.zeros((4, 3), np.int32))


def test_a_benchmark_ground_truth_scores_one_against_itself(shared_data):
    path = shared_data / "maps" / "ipa" / "lab_ipa_gt_segmentation.png"
    if not path.is_file():
        pytest.skip(f"missing {path}")
    truth = read_ground_truth(path)
    s = score_rooms(truth, truth)
    assert s.n_rooms > 5
    assert (s.recall, s.precision, s.mean_iou, s.segments_per_room) == (1.0, 1.0, 1.0, 1.0)


def test_the_rooms_page_quotes_the_published_benchmark_results():
    """docs/rooms.md quotes ``bench/results/rooms_amd-epyc-2cpu.json``: its scores and
    its mean warm and CPU times on all 20 maps, so that the times cannot drift from a
    rerun's."""
    root = Path(__file__).resolve().parents[1]
    results = json.loads((root / "bench" / "results" / "rooms_amd-epyc-2cpu.json").read_text())
    page = " ".join((root / "docs" / "rooms.md").read_text().split())
    plain, furn = (results["averages"][v]["all"] for v in ("plain", "furnitures"))
    for avg, label in ((plain, "without"), (furn, "with")):
        t = avg["topojax"]
        assert f"**{t['recall']:.1f} / {t['precision']:.1f} {label} furniture**" in page
    p, f = plain["topojax"], furn["topojax"]
    assert (
        f"{p['warm_ms']:.0f} ms per map on average without furniture and {f['warm_ms']:.0f} "
        "ms with it" in page
    )
    assert f"({p['warm_cpu_ms']:.0f} and {f['warm_cpu_ms']:.0f} ms of CPU;" in page
    baseline = (plain["baseline"]["warm_ms"] + furn["baseline"]["warm_ms"]) / 2
    assert f"baseline about {10 * round(baseline / 10)} ms" in page
