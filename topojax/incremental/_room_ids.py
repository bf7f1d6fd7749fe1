"""Room ids carried from one segmentation to the next, and label windows in global pixel
boxes (``(r0, c0, r1, c1)``, end exclusive), shared by the whole and the local room
updates."""

from __future__ import annotations

import numpy as np

__all__ = ["SAME_ROOM_IOU", "match_ids", "pasted"]

#: A new room keeps an old room's id when they are each other's largest overlap and
#: overlap at least this much (intersection over union).
SAME_ROOM_IOU = 0.5


def _window(labels: np.ndarray, box, inter) -> np.ndarray:
    """The part of ``labels`` (over global pixel box ``box``) inside box ``inter``."""
    r0, c0 = inter[0] - box[0], inter[1] - box[1]
    return labels[r0 : r0 + inter[2] - inter[0], c0 : c0 + inter[3] - inter[1]]


def match_ids(old, old_box, new, new_box, next_id: int) -> tuple[np.ndarray, int]:
    """Stable ids for the rooms ``1..new.max()`` of ``new`` given the previous labels
    ``old`` (boxes: global ``(r0, c0, r1, c1)``, end exclusive).  Returns the lookup table
    (int64, index = new label, 0 -> 0) and the next unused id."""
    n_new = int(new.max()) if new.size else 0
    lut = np.zeros(n_new + 1, np.int64)
    if n_new == 0:
        return lut, next_id
    if old is not None and old.size and old.max() > 0:
        inter = (
            max(old_box[0], new_box[0]),
            max(old_box[1], new_box[1]),
            min(old_box[2], new_box[2]),
            min(old_box[3], new_box[3]),
        )
        if inter[0] < inter[2] and inter[1] < inter[3]:
            a = _window(old, old_box, inter).ravel().astype(np.int64)
            b = _window(new, new_box, inter).ravel().astype(np.int64)
            both = (a > 0) & (b > 0)
            base = int(old.max()) + 1
            keys, overlap = np.unique(b[both] * base + a[both], return_counts=True)
            nb, na = np.divmod(keys, base)
            area_old = np.bincount(old.ravel(), minlength=base).astype(np.int64)
            area_new = np.bincount(new.ravel(), minlength=n_new + 1).astype(np.int64)
            best_new = np.zeros(n_new + 1, np.int64)  # best old id of each new room
            best_new_ov = np.zeros(n_new + 1, np.int64)
            best_old = np.zeros(base, np.int64)
            best_old_ov = np.zeros(base, np.int64)
            for j, i, ov in zip(nb.tolist(), na.tolist(), overlap.tolist(), strict=True):
                if ov > best_new_ov[j]:
                    best_new[j], best_new_ov[j] = i, ov
                if ov > best_old_ov[i]:
                    best_old[i], best_old_ov[i] = j, ov
            for j in range(1, n_new + 1):
                i = int(best_new[j])
                if i and best_old[i] == j:
                    iou = best_new_ov[j] / (area_old[i] + area_new[j] - best_new_ov[j])
                    if iou >= SAME_ROOM_IOU:
                        lut[j] = i
    for j in range(1, n_new + 1):
        if lut[j] == 0:
            lut[j] = next_id
            next_id += 1
    return lut, next_id


def pasted(labels: np.ndarray, box, union, *, fill=0) -> np.ndarray:
    """``labels`` (over global box ``box``) placed in an array of ``fill`` over box
    ``union``."""
    out = np.full((union[2] - union[0], union[3] - union[1]), fill, labels.dtype)
    r0, c0 = box[0] - union[0], box[1] - union[1]
    out[r0 : r0 + labels.shape[0], c0 : c0 + labels.shape[1]] = labels
    return out
