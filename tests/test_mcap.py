"""ROS 2 MCAP recordings (:mod:`topojax.io.mcap`), read back with readers that are not
the writer: ``rosbags``' AnyReader and, where installed, the ``mcap`` package with its
ROS 2 decoder (the library Foxglove's tools use)."""

from __future__ import annotations

import math
import warnings
from collections import Counter
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

import topojax as tj
from topojax.io.mcap import LASER_FRAME, MAP_FRAME, ROBOT_FRAME, TOPICS, McapRecorder

pytest.importorskip("rosbags")
from rosbags.highlevel import AnyReader  # noqa: E402

DATA = Path(__file__).parent / "data"
INTEL_EXCERPT = DATA / "intel_first40.log.gz"
KIND_IDS = {"junction": 0, "end": 1, "ring": 2, "isolated": 3}


def read_messages(path: Path) -> list[tuple[str, str, int, object]]:
    """``(topic, type, log time ns, message)`` of every message, in file time order."""
    with AnyReader([Path(path)]) as reader:
        return [
            (c.topic, c.msgtype, t, reader.deserialize(raw, c.msgtype))
            for c, t, raw in reader.messages()
        ]


def last(messages, topic: str):
    return [m for tp, _, _, m in messages if tp == topic][-1]


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def headers(msg) -> list:
    """The headers of a message: its own, its transforms' or its markers'."""
    if hasattr(msg, "transforms"):
        return [tf.header for tf in msg.transforms]
    if hasattr(msg, "markers"):
        return [m.header for m in msg.markers]
    return [msg.header]


def grid_masks(grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Occupied, free and unknown masks of an OccupancyGrid, row 0 at the top."""
    h, w = grid.info.height, grid.info.width
    data = np.asarray(grid.data, np.int8).reshape(h, w)[::-1]
    assert set(np.unique(data).tolist()) <= {-1, 0, 100}
    return data == 100, data == 0, data == -1


def assert_grid_is_map(grid, occ) -> None:
    occupied, free, unknown = grid_masks(grid)
    np.testing.assert_array_equal(occupied, occ.occupied)
    np.testing.assert_array_equal(free, occ.free)
    np.testing.assert_array_equal(unknown, occ.unknown)
    assert grid.info.resolution == pytest.approx(occ.resolution_m, rel=1e-6)  # float32
    pos = grid.info.origin.position
    assert (pos.x, pos.y) == pytest.approx(occ.origin[:2], abs=1e-12)
    assert grid.header.frame_id == MAP_FRAME


def assert_markers_are_graph(array, graph) -> None:
    """The markers hold every vertex (a sphere list per kind) and every edge (a line
    strip through its ``waypoints`` where it has them, else its ``world`` points), and
    nothing else after a DELETEALL."""
    markers = array.markers
    assert markers[0].action == 3  # DELETEALL: earlier graphs vanish
    spheres = {m.id: m for m in markers if m.ns == "vertices"}
    for kind, mid in KIND_IDS.items():
        want = sorted(tuple(d["world"]) for _, d in graph.nodes(data=True) if d["kind"] == kind)
        got = sorted((p.x, p.y) for p in spheres[mid].points) if mid in spheres else []
        assert got == pytest.approx(want, abs=1e-9), kind
        if mid in spheres:
            assert spheres[mid].type == 7  # SPHERE_LIST
    strips = [m for m in markers if m.ns == "edges"]
    assert all(m.type == 4 for m in strips)  # LINE_STRIP
    assert all(m.header.frame_id == MAP_FRAME for m in markers)
    got = sorted(tuple(np.round([(p.x, p.y) for p in m.points], 9).ravel()) for m in strips)
    want = sorted(
        tuple(np.round(np.asarray(d.get("waypoints", d["world"]), float), 9).ravel())
        for *_, d in graph.edges(data=True)
    )
    assert got == want
    assert len(markers) == 1 + len(spheres) + len(strips)


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay")
    path = out / "run.mcap"
    summary = tj.replay(
        INTEL_EXCERPT,
        out_dir=out,
        progress=False,
        graph_every=10,
        skeleton_every=None,
        rooms=True,
        route_graph_radius_m=0.2,
        mcap=path,
    )
    return out, path, summary, read_messages(path)


def test_replay_recording_has_every_topic_with_standard_types_and_counts(replayed):
    out, path, summary, messages = replayed
    assert str(path) in summary["written"]
    assert {tp: ty for tp, ty, _, _ in messages} == TOPICS
    counts = Counter(tp for tp, *_ in messages)
    # 40 scans; a graph (room, route graph) update every 10 scans, and the written result
    # at the end
    assert counts == {
        "/tf_static": 1,
        "/tf": 40,
        "/scan": 40,
        "/map": 5,
        "/topology": 5,
        "/route_graph": 5,
        "/rooms": 5,
    }
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary folder


def test_replaying_a_recording_does_not_record_over_it(replayed, tmp_path):
    """A recording replayed with ``mcap`` naming it is refused before anything is read
    or written: the new recording would replace the log (and any topic it holds besides
    scans)."""
    source = tmp_path / "run.mcap"
    source.write_bytes(replayed[1].read_bytes())
    before = source.read_bytes()
    with pytest.raises(ValueError, match=r"mcap: writing .*run.mcap would overwrite the repl"):
        tj.replay(source, out_dir=tmp_path / "out", progress=False, mcap=tmp_path / "run.mcap")
    assert source.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


def test_replay_recording_uses_the_log_timestamps(replayed):
    _, _, _, messages = replayed
    scans = list(tj.read_scans(INTEL_EXCERPT))
    want = [round(s.timestamp * 1e9) for s in scans]
    assert [t for tp, _, t, _ in messages if tp == "/scan"] == want
    times = [t for _, _, t, _ in messages]
    assert times == sorted(times)
    for tp, _, t, msg in messages:  # each header carries the message's log time
        assert all(stamp_ns(h) == t for h in headers(msg)), tp
    # the maps come with the scans of the graph updates (10, 20, 30, 40) and at the end
    assert [t for tp, _, t, _ in messages if tp == "/map"] == [
        want[9],
        want[19],
        want[29],
        want[39],
        want[39],
    ]


def test_replay_recording_scans_and_poses(replayed):
    _, _, _, messages = replayed
    scans = list(tj.read_scans(INTEL_EXCERPT))
    laser = [m for tp, _, _, m in messages if tp == "/scan"]
    tfs = [m for tp, _, _, m in messages if tp == "/tf"]
    for scan, msg, tf in zip(scans, laser, tfs, strict=True):
        # the log's no-return sentinel (81.83 m, beyond range_max) is REP 117's +inf
        want = np.where(scan.valid_mask(), scan.ranges, np.inf).astype(np.float32)
        np.testing.assert_array_equal(msg.ranges, want)
        assert msg.header.frame_id == LASER_FRAME
        assert msg.angle_min == pytest.approx(scan.angle_min, abs=1e-6)
        assert msg.angle_max == pytest.approx(
            scan.angle_min + (scan.n_beams - 1) * scan.angle_increment, abs=1e-6
        )
        (robot,) = tf.transforms  # the sensor's fixed offset is on /tf_static
        assert (robot.header.frame_id, robot.child_frame_id) == (MAP_FRAME, ROBOT_FRAME)
        x, y, yaw = scan.pose
        q = robot.transform.rotation
        assert (robot.transform.translation.x, robot.transform.translation.y) == (x, y)
        assert math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z) == pytest.approx(yaw, abs=1e-12)


def test_replay_recording_ends_with_the_written_map_graph_and_rooms(replayed):
    out, _, summary, messages = replayed
    assert_grid_is_map(last(messages, "/map"), tj.load_map(out / "map.yaml"))
    graph = tj.load_graph(out / "graph.json")
    assert graph.number_of_edges() == summary["edges"] > 0
    assert_markers_are_graph(last(messages, "/topology"), graph)
    rooms, doors = tj.load_rooms(out / "map_rooms.geojson")
    markers = last(messages, "/rooms").markers
    outlines = {m.id: m for m in markers if m.ns == "rooms"}
    assert sorted(outlines) == sorted(r.id for r in rooms) and rooms
    for room in rooms:
        pts = np.array([(p.x, p.y) for p in outlines[room.id].points])
        np.testing.assert_allclose(pts[:-1], room.polygon, atol=1e-9)
        np.testing.assert_array_equal(pts[-1], pts[0])  # closed
    labels = {m.id: m.text for m in markers if m.ns == "room_ids"}
    assert labels == {r.id: str(r.id) for r in rooms}
    door_lines = [m for m in markers if m.ns == "doors"]
    assert sum(len(m.points) for m in door_lines) == 2 * len(doors)


def test_replay_recording_has_the_route_graph_of_every_graph_update(replayed):
    """/route_graph comes with each /map: the route graph of that map, edges through
    their waypoints; the last one is the written route graph."""
    out, _, _, messages = replayed
    maps = [t for tp, _, t, _ in messages if tp == "/map"]
    assert [t for tp, _, t, _ in messages if tp == "/route_graph"] == maps
    routes = tj.load_graph(out / "route_graph.json")
    assert routes.graph["kind"] == "route_graph" and routes.number_of_edges() > 0
    assert_markers_are_graph(last(messages, "/route_graph"), routes)
    # the first one is the route graph of the first recorded map
    grid = next(m for tp, _, _, m in messages if tp == "/map")
    occupied, free, unknown = grid_masks(grid)
    first_map = tj.OccupancyMap(
        occupied=occupied,
        free=free,
        unknown=unknown,
        resolution_m=tj.load_map(out / "map.yaml").resolution_m,
        origin=(grid.info.origin.position.x, grid.info.origin.position.y, 0.0),
    )
    first = tj.route_graph(first_map, robot_radius_m=0.2)
    assert first.number_of_edges() > 0
    assert_markers_are_graph(next(m for tp, _, _, m in messages if tp == "/route_graph"), first)


def test_route_graph_edges_are_told_apart_from_the_topology_s(replayed):
    """Both are shown together in Foxglove and RViz: the route graph's edges are green,
    the topology's orange (the viewer's first and second graph colours)."""
    _, _, _, messages = replayed

    def edge_rgb(topic):
        (colour,) = {
            (m.color.r, m.color.g, m.color.b)
            for m in last(messages, topic).markers
            if m.ns == "edges"
        }
        return tuple(round(255 * v) for v in colour)

    assert edge_rgb("/topology") == (0xFF, 0x7F, 0x0E)
    assert edge_rgb("/route_graph") == (0x2C, 0xA0, 0x2C)


def test_replay_recording_reads_with_the_mcap_package(replayed):
    """The file is plain MCAP with the ros2 profile, as Foxglove reads it."""
    pytest.importorskip("mcap_ros2")
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out, path, _, _ = replayed
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        decoded = [
            (ch.topic, schema.name, msg.log_time, ros)
            for schema, ch, msg, ros in reader.iter_decoded_messages(log_time_order=True)
        ]
    assert {tp: ty for tp, ty, _, _ in decoded} == TOPICS
    assert Counter(tp for tp, *_ in decoded)["/scan"] == 40
    grid = [m for tp, _, _, m in decoded if tp == "/map"][-1]
    occ = tj.load_map(out / "map.yaml")
    data = np.frombuffer(bytes(np.asarray(grid.data, np.int8)), np.int8)
    np.testing.assert_array_equal(
        data.reshape(grid.info.height, grid.info.width)[::-1] == 100, occ.occupied
    )


def test_every_chunk_carries_the_crc_of_its_records(replayed, tmp_path):
    """Each chunk records the CRC-32 of its uncompressed records (0 means none, and damage
    that still decompresses would pass unseen): the mcap package's reader checks them, and
    topojax's readers refuse a recording whose chunk does not match its CRC."""
    import zlib

    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    _, path, _, _ = replayed
    with open(path, "rb") as f:
        chunks = [r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk)]
    with open(path, "rb") as f:  # the reader that checks the CRCs reads every record
        assert len(list(StreamReader(f, validate_crcs=True).records)) > len(chunks) >= 2
    for chunk in chunks:
        assert chunk.compression == "zstd"
        records = zstd_decompress(chunk.data, chunk.uncompressed_size)
        assert chunk.uncompressed_crc == zlib.crc32(records) != 0
    # the first chunk follows the magic (8 bytes) and the header record (opcode, length)
    data = bytearray(path.read_bytes())
    chunk_at = 8 + 9 + int.from_bytes(data[9:17], "little")
    assert data[chunk_at] == 0x06
    data[chunk_at + 9 + 24] ^= 0x01  # its CRC: start and end times, size, then the CRC
    for name, cut in (("bad_crc.mcap", 0), ("bad_crc_cut.mcap", 30)):
        bad = tmp_path / name
        bad.write_bytes(bytes(data[: len(data) - cut]))
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", ".*is cut off", RuntimeWarning)
            with pytest.raises(ValueError, match=rf"{name[:-5]}\.mcap.*(CRC|checksum)"):
                list(tj.read_scans(bad))


def zstd_decompress(data: bytes, size: int) -> bytes:
    try:
        from compression import zstd  # Python >= 3.14
    except ImportError:
        from backports import zstd  # a dependency of rosbags
    out = zstd.decompress(data)
    assert len(out) == size
    return out


def test_save_mcap_writes_one_map_graph_and_rooms(tmp_path):
    result = tj.build_graph(tj.sample_map("a_scan"))
    seg = tj.segment_rooms(result)
    path = tj.save_mcap(result, tmp_path / "sub" / "a_scan.mcap", rooms=seg)
    assert path == tmp_path / "sub" / "a_scan.mcap"
    messages = read_messages(path)
    assert [(tp, t) for tp, _, t, _ in messages] == [("/map", 0), ("/topology", 0), ("/rooms", 0)]
    assert_grid_is_map(last(messages, "/map"), result.map)
    assert_markers_are_graph(last(messages, "/topology"), result.graph)
    ids = sorted(m.id for m in last(messages, "/rooms").markers if m.ns == "rooms")
    assert ids == sorted(r.id for r in seg.rooms)
    # without rooms there is no /rooms topic; an existing file is replaced
    tj.save_mcap(result, path)
    assert [tp for tp, *_ in read_messages(path)] == ["/map", "/topology"]
    with pytest.raises(TypeError, match="result: expected a TopologyResult"):
        tj.save_mcap(result.map, tmp_path / "x.mcap")
    # a route graph goes to /route_graph, its edges through their waypoints
    routes = tj.route_graph(result.map, robot_radius_m=0.3)
    tj.save_mcap(result, path, route_graph=routes)
    messages = read_messages(path)
    assert [tp for tp, *_ in messages] == ["/map", "/topology", "/route_graph"]
    assert_markers_are_graph(last(messages, "/route_graph"), routes)
    words = "route_graph: expected an undirected networkx graph, received TopologyResult"
    with pytest.raises(TypeError, match=words):
        tj.save_mcap(result, tmp_path / "y.mcap", route_graph=result)
    assert not (tmp_path / "y.mcap").exists()


def _scan(t, x=0.0):
    return tj.Scan.from_arrays(
        np.full(5, 2.0),
        (x, 1.0, 0.5),
        angle_min=-0.2,
        angle_increment=0.1,
        range_max=10.0,
        sensor_offset=(0.2, 0.0, 0.0),
        timestamp=t,
    )


def test_scans_without_usable_timestamps_keep_the_scan_order(tmp_path):
    """Missing timestamps and ones that go back are replaced by the previous stamp plus
    SCAN_PERIOD_S (0.1 s); the first scan without one is at 0 s."""
    path = tmp_path / "r.mcap"
    with McapRecorder(path) as rec:  # a step back of a second: no warning
        stamps = [rec.add_scan(_scan(t)) for t in (None, None, 5.0, 4.0, 6.0)]
    assert stamps == [0, 100_000_000, 5_000_000_000, 5_100_000_000, 6_000_000_000]
    messages = read_messages(path)
    assert [t for tp, _, t, _ in messages if tp == "/scan"] == stamps
    assert rec.counts == {"/tf_static": 1, "/tf": 5, "/scan": 5}
    (sensor,) = last(messages, "/tf_static").transforms
    assert (sensor.header.frame_id, sensor.child_frame_id) == (ROBOT_FRAME, LASER_FRAME)
    sensor = sensor.transform
    assert (sensor.translation.x, sensor.translation.y, sensor.rotation.w) == (0.2, 0.0, 1.0)


def test_a_timestamp_far_ahead_is_said_once_as_it_shifts_the_scans_after_it(tmp_path):
    """A log whose times jump far ahead once (1, 2, 1e6, 3, 4) moves every later scan's
    stamp past the jump (stamps only move forward): said in one warning naming the
    times, not silently."""
    with McapRecorder(tmp_path / "r.mcap") as rec, pytest.warns(UserWarning) as caught:
        stamps = [rec.add_scan(_scan(t)) for t in (1.0, 2.0, 1e6, 3.0, 4.0)]
    assert stamps[3:] == [1_000_000_100_000_000, 1_000_000_200_000_000]
    assert len(caught) == 1
    text = str(caught[0].message)
    assert "the scans' times went back from 1000000 s to 3 s" in text
    assert "0.1 s apart from 1000000 s on" in text
    with McapRecorder(tmp_path / "s.mcap") as rec:  # times first missing: nothing to say
        stamps = [rec.add_scan(_scan(t)) for t in [None] * 200 + [0.5, 30.0]]
    assert stamps[-2:] == [20_000_000_000, 30_000_000_000]


def test_repeated_timestamps_get_distinct_stamps(tmp_path):
    """A timestamp equal to the previous one (all 0 in some CARMEN logs) is not used:
    every scan would land at one instant and tf would drop the repeated transforms."""
    with McapRecorder(tmp_path / "r.mcap") as rec:
        zeros = [rec.add_scan(_scan(0.0)) for _ in range(3)]
    assert zeros == [0, 100_000_000, 200_000_000]
    with McapRecorder(tmp_path / "s.mcap") as rec:
        stamps = [rec.add_scan(_scan(t)) for t in (5.0, 5.0, 5.3)]
    assert stamps == [5_000_000_000, 5_100_000_000, 5_300_000_000]


def test_readings_of_no_return_are_recorded_as_rep_117_s_plus_inf(tmp_path):
    """A reading of 0 (range_min 0), at range_max, beyond it, NaN or below range_min is no
    return to topojax; recorded as read, RViz and Foxglove drew the 0 as a point on the
    laser.  REP 117's no return is +inf; the hits keep their values."""
    ranges = np.array([0.0, 2.0, 10.0, 12.5, np.nan, np.inf, 0.05, 9.999, -1.0])
    scan = tj.Scan.from_arrays(
        ranges, (0.0, 0.0, 0.0), angle_min=-0.4, angle_increment=0.1, range_max=10.0
    )
    with McapRecorder(tmp_path / "r.mcap") as rec:
        rec.add_scan(scan)
    msg = last(read_messages(tmp_path / "r.mcap"), "/scan")
    inf = np.inf
    want = np.array([inf, 2.0, inf, inf, inf, inf, 0.05, 9.999, inf], np.float32)
    np.testing.assert_array_equal(msg.ranges, want)
    assert (msg.range_min, msg.range_max) == (0.0, 10.0)
    near = tj.Scan.from_arrays(
        ranges, (0, 0, 0), angle_min=-0.4, angle_increment=0.1, range_min=0.1, range_max=10.0
    )
    with McapRecorder(tmp_path / "s.mcap") as rec:
        rec.add_scan(near)
    msg = last(read_messages(tmp_path / "s.mcap"), "/scan")
    np.testing.assert_array_equal(msg.ranges[6], np.float32(inf))  # below range_min


def test_hits_rounded_onto_a_limit_in_float32_stay_hits(tmp_path):
    """LaserScan readings are float32.  A float64 hit just below ``range_max`` rounds to
    the float32 ``range_max`` (a max-range no return on reading back), and a hit of 1e-60 m
    with ``range_min`` 0 rounds to 0: both are recorded as the nearest float32 inside the
    limits, so every hit reads back as a hit."""
    below = np.nextafter(5.6, 0.0)  # < 5.6, but float32(below) == float32(5.6)
    assert np.float32(below) == np.float32(5.6)
    ranges = np.array([below, 1e-60, 2.0, 5.6])
    scan = tj.Scan.from_arrays(
        ranges, (0.0, 0.0, 0.0), angle_min=-0.1, angle_increment=0.1, range_max=5.6
    )
    assert scan.valid_mask().tolist() == [True, True, True, False]
    with McapRecorder(tmp_path / "r.mcap") as rec:
        rec.add_scan(scan)
    (back,) = tj.read_scans(tmp_path / "r.mcap")
    assert back.valid_mask().tolist() == [True, True, True, False]
    assert back.ranges[0] == np.nextafter(np.float32(5.6), np.float32(0))
    assert back.ranges[1] == np.nextafter(np.float32(0), np.float32(1))
    assert back.ranges[2] == np.float32(2.0)


def test_a_recording_read_back_maps_as_the_log(tmp_path):
    """topojax's bag reader reads a recording back to scans that hit where the log's hit
    (no returns, 0 and range_max readings among them, read back as +inf) and map to the
    same occupancy."""
    from topojax.incremental import IncrementalMapper

    scans = []
    for i, s in enumerate(tj.read_scans(INTEL_EXCERPT)):
        r = np.array(s.ranges)
        r[i % 7 :: 11] = 0.0
        r[i % 5 :: 13] = s.range_max
        scans.append(
            tj.Scan(r, s.angle_min, s.angle_increment, 0.0, s.range_max, s.pose, s.sensor_offset)
        )
    assert sum((s.ranges >= s.range_max).sum() for s in scans) > 900
    assert sum((s.ranges == 0.0).sum() for s in scans) > 500
    with McapRecorder(tmp_path / "r.mcap") as rec:
        for s in scans:
            rec.add_scan(s)
    back = list(tj.read_scans(tmp_path / "r.mcap"))
    assert len(back) == len(scans)
    for a, b in zip(scans, back, strict=True):
        np.testing.assert_array_equal(b.valid_mask(), a.valid_mask())
        np.testing.assert_array_equal(b.ranges[~b.valid_mask()], np.inf)
        assert b.range_max == pytest.approx(a.range_max, rel=1e-7)  # float32 in the message
    maps = []
    for run in (scans, back):
        mapper = IncrementalMapper(skeleton_every=0, graph_every=0)
        mapper.add_scans(run)
        maps.append(mapper.occupancy)
    for name in ("occupied", "free", "unknown"):
        np.testing.assert_array_equal(getattr(maps[1], name), getattr(maps[0], name))
    assert maps[1].origin == maps[0].origin and maps[0].occupied.any()


def raw_messages(path: Path) -> list[tuple[str, int, bytes]]:
    with AnyReader([Path(path)]) as reader:
        return sorted((c.topic, t, bytes(raw)) for c, t, raw in reader.messages())


def test_a_recording_continues_one_closed_part_way(tmp_path):
    """A replay stopped part way closes its recording aside; the resumed replay's
    recording starts with its messages and stamps on from its last scan."""
    stamps = (1.0, None, 2.0, 2.0, 3.0)
    with McapRecorder(tmp_path / "whole.mcap") as rec:
        for t in stamps:
            rec.add_scan(_scan(t))
    rec = McapRecorder(tmp_path / "r.mcap").open()
    for t in stamps[:3]:
        rec.add_scan(_scan(t))
    part = rec.close(tmp_path / "part" / "part.mcap")
    assert part == tmp_path / "part" / "part.mcap" and not (tmp_path / "r.mcap").exists()
    with McapRecorder(tmp_path / "r.mcap", continue_from=part) as rec:
        assert rec.stamp_ns == 2_000_000_000
        assert rec.counts == {"/tf_static": 1, "/tf": 3, "/scan": 3}
        for t in stamps[3:]:
            rec.add_scan(_scan(t))
    assert raw_messages(tmp_path / "r.mcap") == raw_messages(tmp_path / "whole.mcap")
    with pytest.raises(FileNotFoundError, match="continue_from: no recording .*none.mcap"):
        with McapRecorder(tmp_path / "s.mcap", continue_from=tmp_path / "none.mcap"):
            pass
    assert not (tmp_path / "s.mcap").exists()
    with pytest.raises(ValueError, match=r"continue_from: expected a file name ending in \.mcap"):
        McapRecorder(tmp_path / "s.mcap", continue_from=tmp_path / "r.bag")


@pytest.mark.parametrize(
    "damage",
    ["not MCAP", "empty", "cut short", "summary damaged"],
)
def test_continuing_a_damaged_recording_names_it_and_leaves_nothing(tmp_path, damage):
    with McapRecorder(tmp_path / "part.mcap") as rec:
        for t in (1.0, 2.0, 3.0):
            rec.add_scan(_scan(t))
    whole = (tmp_path / "part.mcap").read_bytes()
    data = {
        "not MCAP": b"not a recording at all",
        "empty": b"",
        "cut short": whole[: len(whole) // 2],
        "summary damaged": whole[:-200] + b"\x01" * 192 + whole[-8:],
    }[damage]
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(data)
    with pytest.raises(
        ValueError, match=r"^continue_from: expected a complete MCAP recording .*bad\.mcap"
    ):
        McapRecorder(tmp_path / "out" / "r.mcap", continue_from=bad).open()
    assert list((tmp_path / "out").iterdir()) == []  # no recording, no temporary folder


def test_a_recorder_writes_one_recording(tmp_path):
    rec = McapRecorder(tmp_path / "r.mcap").open()
    with pytest.raises(RuntimeError, match="r.mcap is already open"):
        rec.open()
    rec.add_scan(_scan(1.0))
    with pytest.raises(ValueError, match=r"path: expected a file name ending in \.mcap"):
        rec.close(tmp_path / "r.txt")
    rec.add_scan(_scan(2.0))  # still open: a wrong name loses nothing
    rec.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.mcap"]
    assert [t for tp, _, t, _ in read_messages(tmp_path / "r.mcap") if tp == "/scan"] == [
        1_000_000_000,
        2_000_000_000,
    ]
    with pytest.raises(RuntimeError, match="is finished .*no more messages"):
        rec.add_scan(_scan(3.0))
    with pytest.raises(RuntimeError, match="is finished .*make a new McapRecorder"):
        with rec:
            pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.mcap"]


def test_a_recorder_prints_its_file_state_and_counts(tmp_path):
    """A recorder's repr says which file it writes, whether it records and what it wrote
    so far, not its address."""
    path = tmp_path / "r.mcap"
    rec = McapRecorder(path)
    assert repr(rec) == f"McapRecorder({str(path)!r}, not open)"
    rec.open()
    rec.add_scan(_scan(1.0))
    rec.add_scan(_scan(2.0))
    assert repr(rec) == (
        f"McapRecorder({str(path)!r}, recording: /tf_static 1, /tf 2, /scan 2; "
        "last scan at 2.000000000 s)"
    )
    rec.close()
    assert repr(rec).startswith(f"McapRecorder({str(path)!r}, finished: /tf_static 1, ")
    later = McapRecorder(tmp_path / "s.mcap", continue_from=path)
    assert repr(later) == (
        f"McapRecorder({str(tmp_path / 's.mcap')!r}, not open, continuing {str(path)!r})"
    )


def test_a_scan_whose_sensor_pose_overflows_is_refused(tmp_path):
    far = tj.Scan.from_arrays(
        np.full(5, 2.0), (1.7e308, 0.0, 0.0), angle_min=-0.2, angle_increment=0.1
    )
    # Scan refuses an offset beyond 100 m, which no finite pose overflows with; one set
    # past its checks still writes nothing
    object.__setattr__(far, "sensor_offset", (1.7e308, 0.0, 0.0))
    with McapRecorder(tmp_path / "r.mcap") as rec:
        rec.add_scan(_scan(1.0))
        with pytest.raises(
            ValueError, match=r"^scan: expected a sensor pose in the map frame .*inf"
        ):
            rec.add_scan(far)
    assert rec.counts == {"/tf_static": 1, "/tf": 1, "/scan": 1} and rec.stamp_ns == 1_000_000_000


def test_recorder_leaves_nothing_behind_on_error_and_checks_its_path(tmp_path):
    with pytest.raises(RuntimeError, match="boom"):
        with McapRecorder(tmp_path / "r.mcap") as rec:
            rec.add_scan(_scan(1.0))
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=r"path: expected a file name ending in \.mcap"):
        McapRecorder(tmp_path / "r.bag")
    (tmp_path / "d.mcap").mkdir()
    with pytest.raises(IsADirectoryError, match="path: expected an .mcap file name"):
        McapRecorder(tmp_path / "d.mcap")
    with pytest.raises(RuntimeError, match="open the recording first"):
        McapRecorder(tmp_path / "r.mcap").add_scan(_scan(1.0))
    with McapRecorder(tmp_path / "r.mcap") as rec:
        with pytest.raises(TypeError, match="scan: expected a topojax.Scan"):
            rec.add_scan("scan")
        with pytest.raises(TypeError, match="occupancy: expected an OccupancyMap"):
            rec.add_map(np.zeros((4, 4)), None)
        g = nx.MultiGraph()
        g.add_node(0, pixel=(0, 0))
        with pytest.raises(ValueError, match="graph: expected a 'world'"):
            rec.add_route_graph(g)
        g.nodes[0]["world"] = (0.0, 0.0)
        g.add_node(1, world=(1.0, 0.0))
        g.add_edge(0, 1, path=np.zeros((2, 2), np.int32))
        with pytest.raises(ValueError, match="graph: expected 'waypoints' or 'world'"):
            rec.add_route_graph(g)
        with pytest.raises(TypeError, match="graph: expected a networkx graph"):
            rec.add_map(tj.sample_map("a_scan"), {"nodes": []})
    assert rec.counts == {}
    # replay checks the name before it replays anything
    with pytest.raises(ValueError, match="mcap: expected a file name ending in .mcap"):
        tj.replay(INTEL_EXCERPT, out_dir=tmp_path / "o", mcap=tmp_path / "r.txt")
    assert not (tmp_path / "o").exists()


def test_command_line_writes_recordings(tmp_path, capsys):
    from topojax.cli import main

    a_scan = Path(tj.datasets.sample_map_path("a_scan"))
    assert (
        main(["graph", str(a_scan), "-o", str(tmp_path), "--mcap", str(tmp_path / "a.mcap")]) == 0
    )
    assert [tp for tp, *_ in read_messages(tmp_path / "a.mcap")] == ["/map", "/topology"]
    assert str(tmp_path / "a.mcap") in capsys.readouterr().out
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "r"), "--no-progress"]
    args += ["--max-scans", "12", "--graph-every", "6", "--mcap", str(tmp_path / "r.mcap")]
    assert main(args) == 0
    counts = Counter(tp for tp, *_ in read_messages(tmp_path / "r.mcap"))
    assert counts == {"/tf_static": 1, "/tf": 12, "/scan": 12, "/map": 3, "/topology": 3}
    # a recording written by another command is not replaced
    other = ["graph", str(a_scan), "-o", str(tmp_path / "g2"), "--mcap", str(tmp_path / "r.mcap")]
    assert main(other) != 0
    assert "--mcap" in capsys.readouterr().err
    assert main(["graph", str(a_scan), "-o", str(tmp_path), "--mcap", str(tmp_path)]) != 0
    # the route graph command records the map and its route graph
    rg = ["route-graph", str(a_scan), "-o", str(tmp_path / "rg"), "--mcap"]
    assert main([*rg, str(tmp_path / "rg.mcap")]) == 0
    messages = read_messages(tmp_path / "rg.mcap")
    assert [tp for tp, *_ in messages] == ["/map", "/route_graph"]
    assert_markers_are_graph(
        last(messages, "/route_graph"), tj.load_graph(tmp_path / "rg" / "a_scan_route.json")
    )
    assert str(tmp_path / "rg.mcap") in capsys.readouterr().out
    assert main([*rg, str(tmp_path / "rg.bag")]) != 0
    assert "--mcap: expected a file name ending in .mcap" in capsys.readouterr().err


def test_save_mcap_names_a_wrong_rooms_argument(tmp_path):
    """A wrong ``rooms`` is named as ``rooms`` (not as ``seg``, the argument of the
    recorder's ``add_rooms``), before the file is opened."""
    result = tj.build_graph(tj.OccupancyMap.from_array(np.eye(16, dtype=bool)))
    with pytest.raises(TypeError, match="^rooms: expected a RoomSegmentation, received str"):
        tj.save_mcap(result, tmp_path / "a.mcap", rooms="rooms.json")
    assert not (tmp_path / "a.mcap").exists()


def test_save_mcap_refuses_rooms_and_a_route_graph_of_another_map(tmp_path):
    """The recording puts every topic in the one map frame: rooms or a route graph made
    on another map (another origin or shape) would sit off their place over ``/map``
    in RViz without a word, so they are refused, named, before the file is opened."""
    walls = ~np.pad(np.ones((30, 40), bool), 2)  # True = occupied: a room in its walls
    result = tj.build_graph(tj.OccupancyMap.from_array(walls))
    moved = tj.OccupancyMap.from_array(walls, origin=(1.0, -2.0, 0.3))
    path = tmp_path / "a.mcap"
    with pytest.raises(ValueError, match="^route_graph: .*origin"):
        tj.save_mcap(result, path, route_graph=tj.route_graph(moved, robot_radius_m=0.1))
    with pytest.raises(ValueError, match="^rooms: .*origin"):
        tj.save_mcap(result, path, rooms=tj.segment_rooms(moved))
    wider = tj.OccupancyMap.from_array(~np.pad(np.ones((30, 50), bool), 2))
    with pytest.raises(ValueError, match="^rooms: .*shape"):
        tj.save_mcap(result, path, rooms=tj.segment_rooms(wider))
    assert not path.exists()
    # those of the result's own map are recorded
    own = tj.route_graph(result.map, robot_radius_m=0.1)
    assert own.number_of_edges() > 0
    tj.save_mcap(result, path, rooms=tj.segment_rooms(result), route_graph=own)
    assert [tp for tp, *_ in read_messages(path)] == ["/map", "/topology", "/rooms", "/route_graph"]


def test_save_mcap_names_a_tiled_result_as_its_result_argument(tmp_path):
    """A :func:`topojax.build_graph_tiled` result, whose map stays on disk, is refused
    as ``result``, the argument given, not as the recorder's ``occupancy``."""
    occ = tj.OccupancyMap.from_array(np.pad(np.ones((30, 40), bool), 2))
    tiled = tj.build_graph_tiled(occ)
    with pytest.raises(TypeError, match="^result: expected a TopologyResult .* TiledResult"):
        tj.save_mcap(tiled, tmp_path / "a.mcap")
    assert not (tmp_path / "a.mcap").exists()


def test_room_markers_write_each_id_inside_its_room():
    from room_maps import ring_round_a_room

    from topojax.io.mcap import room_markers

    seg = ring_round_a_room(origin=(1.0, -2.0, 0.4))
    assert seg.room_at(seg.rooms[0].centroid) == 2, "the ring's centroid is in room 2"
    ids = [m for m in room_markers(seg).markers if m.ns == "room_ids"]
    assert [m.id for m in ids] == [1, 2]
    for m, room in zip(ids, seg.rooms, strict=True):
        at = (m.pose.position.x, m.pose.position.y)
        assert m.text == str(room.id) and at == pytest.approx(room.label_point)
        assert seg.room_at(at) == room.id


def test_room_markers_draw_the_rings_round_a_rooms_holes():
    from room_maps import corridor_round_two_rooms

    from topojax.io.mcap import room_markers

    seg = corridor_round_two_rooms()
    corridor = seg.rooms[0]
    assert len(corridor.holes) == 2 and not any(r.holes for r in seg.rooms[1:])
    markers = room_markers(seg).markers
    (holes,) = [m for m in markers if m.ns == "room_holes"]
    outline = next(m for m in markers if m.ns == "rooms" and m.id == corridor.id)
    assert holes.id == corridor.id and holes.type == 5  # LINE_LIST
    assert (holes.color.r, holes.color.g, holes.color.b) == (
        outline.color.r,
        outline.color.g,
        outline.color.b,
    )
    pts = np.array([(p.x, p.y) for p in holes.points]).reshape(-1, 2, 2)
    want = [
        np.stack([h, np.roll(h, -1, axis=0)], axis=1) for h in corridor.holes
    ]  # each hole's sides, in ring order
    np.testing.assert_allclose(pts, np.concatenate(want), atol=1e-9)


def test_markers_refuse_coordinates_that_are_not_finite_x_y_pairs(tmp_path):
    """A NaN in a vertex's ``world`` or an edge's ``waypoints`` (RViz drops such a
    marker with a warning) and a vertex ``world`` of three numbers (which fails inside
    numpy's reshape) are refused naming the graph, vertex or edge, not written into the
    markers."""
    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), kind="end")
    g.add_node(1, world=(1.0, 0.0), kind="end")
    g.add_edge(0, 1, waypoints=np.array([[0.0, 0.0], [np.nan, 0.0]]))
    with McapRecorder(tmp_path / "r.mcap") as rec:
        with pytest.raises(ValueError, match=r"graph: edge \(0, 1, 0\) 'waypoints': expected"):
            rec.add_route_graph(g)
        g.edges[0, 1, 0]["waypoints"] = np.array([[0.0, 0.0], [1.0, 0.0]])
        g.nodes[1]["world"] = (1.0, math.inf)
        with pytest.raises(ValueError, match=r"graph: node 1 'world': expected"):
            rec.add_route_graph(g)
        g.nodes[1]["world"] = (1.0, 0.0, 0.0)
        with pytest.raises(ValueError, match=r"graph: node 1 'world': expected"):
            rec.add_route_graph(g)
        g.nodes[1]["world"] = (1.0, 0.0)
        g.edges[0, 1, 0]["waypoints"] = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        with pytest.raises(ValueError, match=r"graph: edge \(0, 1, 0\) 'waypoints': expected"):
            rec.add_route_graph(g)
        del g.edges[0, 1, 0]["waypoints"]
        g.edges[0, 1, 0]["world"] = [[0.0, 0.0], [1.0, float("nan")]]
        with pytest.raises(ValueError, match=r"graph: edge \(0, 1, 0\) 'world': expected"):
            rec.add_map(tj.sample_map("a_scan"), g)
        g.edges[0, 1, 0]["world"] = [[0.0, 0.0], [1.0, 0.0]]
        rec.add_route_graph(g)
    assert rec.counts == {"/route_graph": 1}
    # save_mcap names its own argument, before it writes anything
    result = tj.build_graph(tj.sample_map("a_scan"))
    g.nodes[0]["world"] = (float("nan"), 0.0)
    with pytest.raises(ValueError, match=r"^route_graph: node 0 'world': expected"):
        tj.save_mcap(result, tmp_path / "s.mcap", route_graph=g)
    assert not (tmp_path / "s.mcap").exists()


def test_a_directed_route_graph_is_refused_as_the_other_readers_refuse_it(tmp_path):
    """A route graph's corridors run both ways: a directed graph, which ``save_graph``,
    ``evaluate_route_graph`` and ``RoutePlanner`` refuse, was drawn into ``/route_graph``
    without a word, by the recorder and by ``save_mcap``."""
    g = nx.DiGraph()
    g.add_node(0, world=(0.0, 0.0), kind="end")
    g.add_node(1, world=(1.0, 0.0), kind="end")
    g.add_edge(0, 1, waypoints=np.array([[0.0, 0.0], [1.0, 0.0]]))
    with McapRecorder(tmp_path / "r.mcap") as rec:
        for directed in (g, nx.MultiDiGraph(g)):
            words = (
                "^graph: expected an undirected networkx graph, received "
                f"{type(directed).__name__}$"
            )
            with pytest.raises(TypeError, match=words):
                rec.add_route_graph(directed)
        rec.add_route_graph(nx.MultiGraph(g))  # the same graph, undirected
        rec.add_map(tj.sample_map("a_scan"), g)  # /topology draws any graph, as before
    assert rec.counts == {"/route_graph": 1, "/map": 1, "/topology": 1}
    result = tj.build_graph(tj.sample_map("a_scan"))
    words = "^route_graph: expected an undirected networkx graph, received DiGraph$"
    with pytest.raises(TypeError, match=words):
        tj.save_mcap(result, tmp_path / "s.mcap", route_graph=g)
    assert not (tmp_path / "s.mcap").exists()


def test_vertices_of_other_kinds_are_drawn_not_dropped():
    """A vertex without one of the four kinds (a graph of another tool, read with
    ``load_graph``) is drawn in a fifth sphere list, as the viewer draws it as "other",
    rather than left out of ``/topology`` without a word."""
    from topojax.io.mcap import graph_markers

    g = nx.MultiGraph()
    g.add_node(0, world=(0.0, 0.0), kind="junction")
    g.add_node(1, world=(1.0, 0.0))
    g.add_node(2, world=(2.0, 0.0), kind="door")
    g.add_edge(0, 1, world=[[0.0, 0.0], [1.0, 0.0]])
    g.add_edge(1, 2, world=[[1.0, 0.0], [2.0, 0.0]])
    spheres = {m.id: m for m in graph_markers(g).markers if m.ns == "vertices"}
    assert sorted(spheres) == [KIND_IDS["junction"], 4]
    assert [(p.x, p.y) for p in spheres[4].points] == [(1.0, 0.0), (2.0, 0.0)]
    assert spheres[4].type == 7 and spheres[4].color.a == 1.0 and spheres[4].scale.x > 0
