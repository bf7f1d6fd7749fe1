"""Room segmentation scores of the IPA room-segmentation benchmark (Bormann et al., ICRA 2016).

The rules follow the benchmark's own evaluation:

* **ground-truth rooms** are the 8-connected regions of pixels brighter than 250 in the
  ground-truth image read as grey (``cv2.IMREAD_GRAYSCALE``); the image is the map with
  extra black lines between rooms;
* **segments** are the pixels of each label > 0 of the predicted label image (a label
  need not be connected);
* regions (rooms and segments) of 100 pixels or fewer are left out on both sides;
* **precision** of a segment: its largest pixel overlap with one room / its area;
  **recall** of a room: its largest overlap with one segment / its area; each averaged
  over the regions (the benchmark's "micro" averages).

Added here: the **IoU** of each room with its best-matching segment (largest overlap /
union), averaged over the rooms, and **segments per room** (segments / rooms, both over
100 px).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

__all__ = [
    "MIN_REGION_PX",
    "RoomScores",
    "ground_truth_rooms",
    "read_ground_truth",
    "score_rooms",
]

#: Regions of this many pixels or fewer are ignored on both sides.
MIN_REGION_PX = 100
#: Grey level a ground-truth pixel must exceed to be inside a room.
GT_FREE_ABOVE = 250


@dataclass(frozen=True)
class RoomScores:
    """Scores of one predicted label image against one ground truth.

    Attributes
    ----------
    recall, precision, mean_iou : float
        Fractions in [0, 1]; NaN where there is no region to average over (no room for
        recall and IoU, no segment for precision).
    segments_per_room : float
        ``n_segments / n_rooms`` (NaN without rooms).
    n_rooms, n_segments : int
        Rooms and segments over :data:`MIN_REGION_PX` pixels.
    """

    recall: float
    precision: float
    mean_iou: float
    segments_per_room: float
    n_rooms: int
    n_segments: int

    def as_dict(self) -> dict:
        return asdict(self)


def ground_truth_rooms(grey: np.ndarray) -> np.ndarray:
    """Room labels of a ground-truth image.

    Parameters
    ----------
    grey : uint8 (H, W)
        The ground-truth image as grey levels.

    Returns
    -------
    int32 (H, W)
        1.. for the 8-connected regions of pixels > 250, 0 elsewhere (small rooms are
        kept here; :func:`score_rooms` leaves them out).
    """
    grey = np.asarray(grey)
    if grey.ndim != 2:
        raise ValueError(f"grey: expected a 2-D grey image, received shape {grey.shape}")
    inside = (grey > GT_FREE_ABOVE).astype(np.uint8)
    _, labels = cv2.connectedComponents(inside, connectivity=8, ltype=cv2.CV_32S)
    return labels


def read_ground_truth(path: str | Path) -> np.ndarray:
    """Room labels (int32 (H, W), 0 = no room) of a ``*_gt_segmentation.png`` file."""
    grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if grey is None:
        raise FileNotFoundError(f"path: cannot read an image at {path}")
    return ground_truth_rooms(grey)


def _large_regions(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(compact index per pixel, -1 for none or a small region; area of each kept region)."""
    flat = labels.ravel()
    if flat.size and flat.max() > flat.size:  # sparse ids (e.g. colours): make them dense
        flat = np.unique(flat, return_inverse=True)[1].reshape(-1) + (flat.min() > 0)
    counts = np.bincount(np.where(flat > 0, flat, 0))
    counts[0] = 0
    keep = counts > MIN_REGION_PX
    index = np.full(counts.size, -1, np.int64)
    index[keep] = np.arange(int(keep.sum()))
    return index[flat], counts[keep].astype(np.float64)


def score_rooms(predicted: np.ndarray, truth: np.ndarray) -> RoomScores:
    """Score a predicted room labelling against ground-truth rooms.

    Parameters
    ----------
    predicted : integer (H, W)
        Segment id of each pixel, 0 = no segment (e.g. ``RoomSegmentation.labels``).
    truth : integer (H, W)
        Room id of each pixel, 0 = no room (:func:`ground_truth_rooms`).

    Returns
    -------
    RoomScores
    """
    predicted, truth = np.asarray(predicted), np.asarray(truth)
    if predicted.shape != truth.shape or predicted.ndim != 2:
        raise ValueError(
            f"predicted: expected the ground truth's 2-D shape {truth.shape}, "
            f"received {predicted.shape}"
        )
    if np.any(predicted < 0) or np.any(truth < 0):
        raise ValueError("predicted, truth: expected labels >= 0")
    seg, seg_area = _large_regions(predicted.astype(np.int64))
    gt, gt_area = _large_regions(truth.astype(np.int64))
    n_seg, n_gt = seg_area.size, gt_area.size
    both = (seg >= 0) & (gt >= 0)
    overlap = np.bincount(seg[both] * n_gt + gt[both], minlength=n_seg * n_gt)
    overlap = overlap.reshape(n_seg, n_gt).astype(np.float64)
    nan = float("nan")
    # as the benchmark: a region with no counterpart has a best overlap of 0, and an
    # average over no region is 0 / 0
    best_per_seg = overlap.max(axis=1) if n_gt else np.zeros(n_seg)
    best_per_gt = overlap.max(axis=0) if n_seg else np.zeros(n_gt)
    precision = float(np.mean(best_per_seg / seg_area)) if n_seg else nan
    recall = float(np.mean(best_per_gt / gt_area)) if n_gt else nan
    if n_seg and n_gt:
        union = gt_area[None, :] + seg_area[:, None] - overlap
        mean_iou = float(np.mean((overlap / union).max(axis=0)))
    else:
        mean_iou = 0.0 if n_gt else nan
    return RoomScores(
        recall=recall,
        precision=precision,
        mean_iou=mean_iou,
        segments_per_room=n_seg / n_gt if n_gt else nan,
        n_rooms=n_gt,
        n_segments=n_seg,
    )
