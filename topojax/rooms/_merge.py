"""From regions split by doorway cuts to rooms: which cuts are doors, and the merging rules
for over-segmentation (doors not narrow compared with their rooms, niches whose doors are
much of their border, tiny regions)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._cuts import Cut
from ._kernels import cut_sides, region_stats

__all__ = ["DoorCut", "merge_regions"]


@dataclass(frozen=True, eq=False)
class DoorCut:
    """A cut kept as a door between final rooms ``rooms`` (ids, ascending)."""

    cut: Cut
    rooms: tuple[int, int]

    def shifted(self, offset: np.ndarray) -> DoorCut:
        """The same door with its pixels moved by ``offset`` (row, col)."""
        c = self.cut
        moved = Cut(
            centre=c.centre + offset,
            ends=c.ends + offset,
            pixels=c.pixels + offset,
            width_px=c.width_px,
        )
        return DoorCut(cut=moved, rooms=self.rooms)


class _Rooms:
    """Union-find over regions with each group's area, largest clearance and border."""

    def __init__(self, area, clear, border) -> None:
        self.parent = np.arange(area.size)
        self.area = area.astype(np.float64)
        self.clear = clear.astype(np.float64)
        self.border = border.astype(np.float64)

    def find(self, x: int) -> int:
        while self.parent[x] != x:
            self.parent[x] = self.parent[self.parent[x]]
            x = int(self.parent[x])
        return int(x)

    def union(self, a: int, b: int, shared_px: float) -> int:
        a, b = self.find(a), self.find(b)
        if a == b:
            return a
        if self.area[a] < self.area[b]:
            a, b = b, a
        self.parent[b] = a
        self.area[a] += self.area[b]
        self.clear[a] = max(self.clear[a], self.clear[b])
        self.border[a] = max(self.border[a] + self.border[b] - 2 * shared_px, 1.0)
        return a


def _merge_pass(rooms: _Rooms, doors: list, cfg, min_area_px: float) -> bool:
    """One pass of the merging rules; returns whether anything merged."""
    changed = False

    # doors that are not narrow compared with both rooms, worst first
    def ratio(d):
        a, b = rooms.find(d[0]), rooms.find(d[1])
        return d[2].width_px / max(min(2 * rooms.clear[a], 2 * rooms.clear[b]), 1e-9)

    for d in sorted(doors, key=ratio, reverse=True):
        a, b = rooms.find(d[0]), rooms.find(d[1])
        if a != b and ratio(d) > cfg.door_ratio:
            rooms.union(a, b, len(d[2].pixels))
            changed = True
    # niches: the doors between two groups are a large share of the smaller one's border
    shared: dict[tuple[int, int], float] = {}
    for a0, b0, cut in doors:
        a, b = rooms.find(a0), rooms.find(b0)
        if a != b:
            key = (min(a, b), max(a, b))
            shared[key] = shared.get(key, 0.0) + len(cut.pixels)
    for (a, b), length in sorted(shared.items(), key=lambda kv: -kv[1]):
        a, b = rooms.find(a), rooms.find(b)
        if a == b:
            continue
        small = a if rooms.area[a] < rooms.area[b] else b
        if length > cfg.max_border_share * rooms.border[small]:
            rooms.union(a, b, length)
            changed = True
    # tiny groups join the neighbour they share the most door length with
    best: dict[int, tuple[float, int]] = {}
    for a0, b0, cut in doors:
        a, b = rooms.find(a0), rooms.find(b0)
        if a == b:
            continue
        for x, y in ((a, b), (b, a)):
            if rooms.area[x] < min_area_px:
                w = len(cut.pixels)
                if w > best.get(x, (-1.0, -1))[0]:
                    best[x] = (w, y)
    for x in sorted(best, key=lambda k: rooms.area[k]):
        y = best[x][1]
        if rooms.find(x) != rooms.find(y) and rooms.area[rooms.find(x)] < min_area_px:
            rooms.union(x, y, best[x][0])
            changed = True
    return changed


def merge_regions(regions, n, clearance, f, cuts, cfg, resolution_m: float):
    """The final room of each region (int32 (n,), ``1..k`` in raster order of the first
    pixel of each room's regions, 0 = no room) and the doors between rooms (list of :class:`DoorCut`);
    ``clearance``: that of the cells of ``f`` x ``f`` pixels."""
    area, clear, border, first = region_stats(regions, clearance.astype(np.float32), f, n)
    area[0] = 0.0
    doors = []
    if cuts:
        starts = np.cumsum([0] + [len(c.pixels) for c in cuts])
        sides = cut_sides(regions, np.concatenate([c.pixels for c in cuts]), starts)
        for (a, b), cut in zip(sides.tolist(), cuts, strict=True):
            if a >= 0:
                doors.append((a, b, cut))
    rooms = _Rooms(area, clear, border)
    min_area_px = cfg.min_room_m2 / resolution_m**2
    while _merge_pass(rooms, doors, cfg, min_area_px):
        pass
    root = np.array([rooms.find(i) for i in range(n)], np.int64)
    joined = np.zeros(n, bool)  # groups with a door to another group
    for a0, b0, _ in doors:
        a, b = rooms.find(a0), rooms.find(b0)
        if a != b:
            joined[a] = joined[b] = True
    # a group with doors is a room from min_room_m2 on, one without from
    # min_isolated_room_m2 on (whichever is larger)
    big = joined[root] & (rooms.area[root] >= min_area_px)
    alone = ~joined[root] & (rooms.area[root] >= cfg.min_isolated_room_m2 / resolution_m**2)
    keep = (big | alone) & (np.arange(n) > 0)
    root = np.where(keep, root, 0)
    groups = np.unique(root[root > 0])
    group_first = np.full(n, np.iinfo(np.int64).max, np.int64)
    np.minimum.at(group_first, root, first)
    order = groups[np.argsort(group_first[groups], kind="stable")]
    final = np.zeros(n, np.int32)
    final[order] = np.arange(1, order.size + 1, dtype=np.int32)
    new_id = final[root]
    kept = []
    for a0, b0, cut in doors:
        a, b = int(new_id[a0]), int(new_id[b0])
        if a > 0 and b > 0 and a != b:
            kept.append(DoorCut(cut=cut, rooms=(min(a, b), max(a, b))))
    return new_id, kept
