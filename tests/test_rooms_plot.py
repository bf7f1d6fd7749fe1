"""Room pictures: :func:`topojax.plotting.plot_rooms` and ``tj.plot(result, rooms=seg)``."""

from __future__ import annotations

import dataclasses

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from room_maps import three_rooms, three_rooms_occupied  # noqa: E402

import topojax as tj  # noqa: E402
from topojax.io.rooms import room_colours  # noqa: E402
from topojax.plotting import plot_rooms  # noqa: E402


@pytest.fixture(scope="module")
def seg():
    return tj.segment_rooms(three_rooms())


def _door_lines(ax) -> list:
    return [c for c in ax.collections if isinstance(c, LineCollection) and c.get_label() == "doors"]


def test_plot_rooms_colours_doors_and_ids(seg):
    ax = plot_rooms(seg)
    base, layer = ax.images
    assert base.get_array().shape == seg.labels.shape, "the map, in pixel coordinates"
    rgba = np.asarray(layer.get_array())
    colours = room_colours(seg.n_rooms) / 255.0
    for room in seg.rooms:
        r, c = np.argwhere(seg.labels == room.id)[0]
        np.testing.assert_allclose(rgba[r, c, :3], colours[room.id - 1], atol=1e-6)
        assert rgba[r, c, 3] > 0
    assert (rgba[seg.labels == 0, 3] == 0).all(), "no room: transparent"
    (doors,) = _door_lines(ax)
    for line, door in zip(doors.get_segments(), seg.doors, strict=True):
        np.testing.assert_array_equal(line, door.ends_px[:, ::-1].astype(float))  # (col, row)
    texts = {t.get_text(): t.get_position() for t in ax.texts}
    assert set(texts) == {"1", "2", "3"}
    for room in seg.rooms:
        r, c = seg.occupancy.world_to_pixel(*room.label_point)
        assert texts[str(room.id)] == pytest.approx((c, r))
        assert seg.labels[int(round(float(r))), int(round(float(c)))] == room.id
    assert ax.get_title() == "3 rooms, 2 doors"
    plt.close(ax.figure)


def test_plot_rooms_writes_the_id_of_a_ring_round_a_room_on_the_ring():
    from room_maps import ring_round_a_room

    seg = ring_round_a_room()
    ring = seg.rooms[0]
    assert seg.room_at(ring.centroid) == 2, "the ring's centroid is in the room it encloses"
    ax = plot_rooms(seg)
    for text in ax.texts:
        c, r = text.get_position()
        assert seg.labels[int(round(r)), int(round(c))] == int(text.get_text())
    plt.close(ax.figure)


def test_plot_rooms_title_counts_one_door_in_the_singular():
    occ = three_rooms_occupied()
    occ[:, 100] = True  # the second doorway walled up: three rooms, one door
    one_door = tj.segment_rooms(tj.OccupancyMap.from_array(occ, resolution_m=0.05))
    assert (one_door.n_rooms, len(one_door.doors)) == (3, 1)
    ax = plot_rooms(one_door)
    assert ax.get_title() == "3 rooms, 1 door"
    plt.close(ax.figure)


def test_the_legend_draws_the_doors_white_line_with_its_dark_outline(seg):
    for ax in (plot_rooms(seg), tj.plot(tj.build_graph(seg.occupancy), rooms=seg)):
        legend = ax.get_legend()
        (door,) = [
            h
            for h, t in zip(legend.legend_handles, legend.get_texts(), strict=True)
            if t.get_text() == "doors"
        ]
        (doors,) = _door_lines(ax)
        assert door.get_path_effects() == doors.get_path_effects() != []
        assert matplotlib.colors.to_hex(door.get_color()) == "#ffffff"
        plt.close(ax.figure)


def test_plot_rooms_without_doors_or_labels(seg):
    fig, ax = plt.subplots()
    assert plot_rooms(seg, ax=ax, doors=False, labels=False, title="x") is ax
    assert not _door_lines(ax) and not ax.texts and ax.get_title() == "x"
    plt.close(fig)
    with pytest.raises(TypeError, match="seg: expected a RoomSegmentation, received str"):
        plot_rooms("rooms.geojson")


def test_plot_overlay_takes_the_rooms_of_its_map(seg):
    result = tj.build_graph(three_rooms())
    ax = tj.plot(result, rooms=seg)
    graph_lines = [
        c for c in ax.collections if isinstance(c, LineCollection) and c.get_label() != "doors"
    ]
    assert len(graph_lines) == 1 and len(_door_lines(ax)) == 1
    assert len(graph_lines[0].get_segments()) == result.graph.number_of_edges()
    assert len(ax.images) == 3, "map, rooms, skeleton"
    assert ax.get_title().endswith(", 3 rooms")
    plt.close(ax.figure)
    wall = np.ones((10, 10), bool)
    other = tj.segment_rooms(tj.OccupancyMap(occupied=wall, free=~wall, unknown=~wall))
    with pytest.raises(
        ValueError,
        match=r"rooms: not of the result's map: expected a map of shape \(60, 150\), "
        r"received the rooms' map of shape \(10, 10\)",
    ):
        tj.plot(result, rooms=other)
    moved = tj.segment_rooms(dataclasses.replace(result.map, origin=(1.0, 0.0, 0.0)))
    with pytest.raises(ValueError, match=r"rooms: not of the result's map: .*origin"):
        tj.plot(result, rooms=moved)  # would be drawn a metre off
    coarse = tj.segment_rooms(dataclasses.replace(result.map, resolution_m=0.1))
    with pytest.raises(ValueError, match=r"rooms: not of the result's map: .* m/px"):
        tj.plot(result, rooms=coarse)
    with pytest.raises(TypeError, match="rooms: expected a RoomSegmentation"):
        tj.plot(result, rooms=3)
    plt.close("all")
