"""Maps larger than memory: a map read block by block gives build_graph's graph exactly.

The blocks are small (a few kernel tiles) so that many block borders cross corridors and
junctions; every comparison is exact (vertices, edges, paths, world coordinates,
clearances, attributes)."""

from __future__ import annotations

import os
import threading
import warnings
from dataclasses import replace

import numpy as np
import pytest
from floorplans import floor_plan

import topojax as tj
from topojax.config import DistanceConfig, GraphConfig, PipelineConfig, SkeletonConfig
from topojax.graph import GraphStore, skeleton_graph_store
from topojax.graph.sparse import row_skeleton_graph_store
from topojax.maps.tiled import TILE_INDEX, TiledMap
from topojax.outofcore import (
    block_piece,
    block_px_for_budget,
    exact_after_t_removal,
    fields_halo_px,
    remove_t_in_map_order,
    thin_window,
)
from topojax.outofcore.checkpoint import BLOCKS_FOLDER
from topojax.skeleton import remove_t_centres, thin

PAPER = ("intel", "office", "a_scan")
#: A small Gaussian (R = 35 px) and tiles of 64 px: blocks of 64 px with halos of 64 px.
SMALL = PipelineConfig(distance=DistanceConfig.from_pixels(sigma_px=10.0), tile_px=64)
STORE_FIELDS = (
    "node_pixel",
    "node_kind",
    "node_world",
    "node_clearance_m",
    "edge_u",
    "edge_v",
    "edge_keys",
    "path_offsets",
    "path_pixels",
    "path_world",
    "edge_length_m",
    "edge_min_clearance_m",
    "edge_mean_clearance_m",
)


def paper_map(name: str):
    return tj.load_map(f"topojax/data/{name}.png")


def assert_same_graph(tiled, result) -> None:
    """The tiled result's graph is the in-memory result's, array for array."""
    a, b = tiled.graph_store, result.graph_store
    assert a is not None and b is not None
    for name in STORE_FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape, name
        assert np.array_equal(x, y, equal_nan=True), name
    assert a.attrs == b.attrs
    assert np.array_equal(tiled.skeleton_flat(), np.flatnonzero(result.skeleton))


def assert_same_networkx(g1, g2) -> None:
    assert list(g1.nodes) == list(g2.nodes)
    assert list(g1.edges(keys=True)) == list(g2.edges(keys=True))
    for (_, a), (_, b) in zip(g1.nodes(data=True), g2.nodes(data=True), strict=True):
        assert a["pixel"] == b["pixel"] and a["kind"] == b["kind"]
    for (*_, a), (*_, b) in zip(g1.edges(data=True), g2.edges(data=True), strict=True):
        assert np.array_equal(a["path"], b["path"])
        assert a["length_m"] == b["length_m"]
    assert g1.graph == g2.graph


# ----------------------------------------------------------------------- the proof


def blobs(seed: int, shape=(48, 56)) -> np.ndarray:
    """Thick random shapes: what makes thinning take many sub-iterations."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    return ndimage.uniform_filter(rng.random(shape), 7) > 0.5


@pytest.mark.parametrize("method", ["guo_hall", "zhang"])
def test_window_thinning_is_the_whole_images_where_it_says_so(method):
    checked = 0
    for seed in range(12):
        image = blobs(seed)
        whole = thin(image, method=method)
        rng = np.random.default_rng(100 + seed)
        for _ in range(6):
            r0, c0 = rng.integers(0, 20, 2)
            r1, c1 = r0 + rng.integers(8, 28), c0 + rng.integers(8, 36)
            beyond = (r0 > 0, r1 < image.shape[0], c0 > 0, c1 < image.shape[1])
            skel, unsure, _ = thin_window(image[r0:r1, c0:c1], beyond, method)
            sure = ~unsure[1:-1, 1:-1]
            assert np.array_equal(skel[sure].astype(bool), whole[r0:r1, c0:c1][sure])
            checked += int(sure.sum())
    assert checked > 0


def test_window_thinning_of_the_whole_image_is_sure_and_exact():
    image = blobs(3)
    skel, unsure, _ = thin_window(image, (False,) * 4, "guo_hall")
    assert not unsure.any()
    assert np.array_equal(skel.astype(bool), thin(image))


def test_t_removal_in_map_order_of_the_whole_image_is_remove_t_centres():
    for seed in range(6):
        skel = thin(blobs(seed, (40, 40)) | blobs(seed + 50, (40, 40)))
        mine = skel.astype(np.uint8)
        remove_t_in_map_order(mine, 0, 0, *skel.shape)
        assert np.array_equal(mine.astype(bool), remove_t_centres(skel))


def test_t_removal_of_a_window_is_exact_where_it_says_so():
    settled = 0
    for seed in range(10):
        image = blobs(seed) | blobs(seed + 20)
        whole = remove_t_centres(thin(image))
        r0, r1, c0, c1 = 6, 40, 9, 47
        beyond = (True, True, True, True)
        skel, unsure, _ = thin_window(image[r0:r1, c0:c1], beyond, "guo_hall")
        core = (8, 26, 8, 30)
        if exact_after_t_removal(skel, unsure, core):
            remove_t_in_map_order(skel, r0, c0, *image.shape)
            got = skel[core[0] : core[1], core[2] : core[3]].astype(bool)
            want = whole[r0 + core[0] : r0 + core[1], c0 + core[2] : c0 + core[3]]
            assert np.array_equal(got, want)
            settled += 1
    assert settled > 0


def test_a_halo_too_small_to_prove_the_block_gives_no_pixels():
    m = TiledMap.from_occupancy(paper_map("intel"))
    refused = 0
    reach = fields_halo_px(SMALL)
    for r in range(0, 704, 64):
        piece = block_piece(m, (r, r + 64, 320, 384), SMALL, reach + 1)
        if piece.halo_px is None:
            assert piece.flat.size == 0
            refused += 1
    assert refused > 0


def test_row_skeleton_graph_store_is_skeleton_graph_store(tmp_path):
    """Thinned blobs (rings, 2 x 2 blocks, crossings) and random pixel sets."""
    rng = np.random.default_rng(7)
    for seed in range(60):
        skel = thin(blobs(seed, (30, 44))) if seed % 2 else rng.random((24, 30)) < 0.3
        clear = (rng.random(skel.shape) * 9).astype(np.float32) if seed % 3 else None
        want = skeleton_graph_store(skel, clearance_px=clear, resolution_m=0.05)
        flat = np.flatnonzero(skel)
        row_start = np.searchsorted(flat, np.arange(skel.shape[0] + 1) * skel.shape[1])
        got = row_skeleton_graph_store(
            skel.shape,
            row_start,
            (flat % skel.shape[1]).astype(np.int32),
            clearance_px=None if clear is None else clear.ravel()[flat],
            resolution_m=0.05,
            out_dir=tmp_path / str(seed) if seed % 4 == 0 else None,
        )
        for name in STORE_FIELDS:
            assert np.array_equal(getattr(got, name), getattr(want, name), equal_nan=True), name
        assert got.attrs == want.attrs


# ----------------------------------------------------------------------- real maps


@pytest.mark.parametrize("name", PAPER)
def test_paper_maps_in_small_blocks_give_build_graphs_graph(name):
    m = paper_map(name)
    tiled = tj.build_graph_tiled(m, config=SMALL, block_px=64)
    assert tiled.blocks > 100
    assert_same_graph(tiled, tj.build_graph(m, config=SMALL))


def test_default_config_in_blocks_of_one_tile_paths_on_disk(tmp_path):
    m = paper_map("office")
    tiled = tj.build_graph_tiled(m, block_px=256, out_dir=tmp_path / "graph")
    assert (tmp_path / "graph" / "path_pixels.npy").is_file()
    base = tiled.graph_store.path_world
    while base.base is not None and not isinstance(base, np.memmap):
        base = base.base
    assert isinstance(base, np.memmap)
    assert_same_graph(tiled, tj.build_graph(m))


def test_paths_on_disk_replace_an_earlier_graphs_files(tmp_path, monkeypatch):
    import topojax.graph.sparse as sparse

    out = tmp_path / "graph"
    first = tj.build_graph_tiled(paper_map("office"), config=SMALL, block_px=128, out_dir=out)
    kept = np.array(first.graph_store.path_pixels)
    # a second graph in the same folder: the first one's mapped paths are not rewritten
    second = tj.build_graph_tiled(paper_map("intel"), config=SMALL, block_px=128, out_dir=out)
    assert np.array_equal(first.graph_store.path_pixels, kept)
    assert second.graph_store.path_pixels.shape != kept.shape

    def fail(*args, **kwargs):
        raise RuntimeError("interrupted")

    monkeypatch.setattr(sparse, "_edge_values", fail)
    with pytest.raises(RuntimeError, match="interrupted"):
        tj.build_graph_tiled(paper_map("office"), config=SMALL, block_px=128, out_dir=out)
    # no temporary file left, the paths not replaced, and no description: not a store;
    # the finished blocks stay for resume=True
    assert all(p.suffix == ".npy" for p in out.iterdir() if p.name != BLOCKS_FOLDER)
    assert (out / BLOCKS_FOLDER / "build.json").is_file()
    assert np.array_equal(np.load(out / "path_pixels.npy"), second.graph_store.path_pixels)


def stored_arrays(res) -> list[str]:
    fields = GraphStore.__dataclass_fields__
    return [n for n in fields if n != "attrs" and getattr(res.graph_store, n) is not None]


def test_the_paths_folder_always_holds_the_returned_graphs_arrays(tmp_path):
    """With ``out_dir`` the folder holds the returned graph's store, also for an empty
    graph (an all-free map) and with junction clusters merged (built in memory): no
    earlier graph's files are left there."""
    out = tmp_path / "graph"
    tj.build_graph_tiled(paper_map("office"), config=SMALL, block_px=128, out_dir=out)
    empty = tj.build_graph_tiled(np.zeros((40, 50), bool), config=SMALL, out_dir=out)
    assert empty.graph_store.n_edges == 0
    assert np.load(out / "path_pixels.npy").shape == (0, 2)
    assert np.load(out / "path_world.npy").shape == (0, 2)
    merged = PipelineConfig(
        distance=SMALL.distance, graph=GraphConfig(merge_junction_clusters=True), tile_px=64
    )
    res = tj.build_graph_tiled(paper_map("intel"), config=merged, block_px=128, out_dir=out)
    assert np.array_equal(np.load(out / "path_pixels.npy"), res.graph_store.path_pixels)
    assert np.array_equal(np.load(out / "path_world.npy"), res.graph_store.path_world)
    assert_same_graph(res, tj.build_graph(paper_map("intel"), config=merged))
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(["graph_store.json", *(f"{n}.npy" for n in stored_arrays(res))])


@pytest.mark.parametrize(
    "graph",
    [
        GraphConfig(free_space_only=True, merge_junction_clusters=True),
        GraphConfig(min_spur_m=0.5, min_component_m=1.0),
    ],
)
def test_graph_options(graph):
    config = PipelineConfig(
        distance=DistanceConfig.from_pixels(sigma_px=6.0),
        tile_px=32,
        skeleton=SkeletonConfig(thinning="zhang"),
        graph=graph,
    )
    m = paper_map("a_scan")
    tiled = tj.build_graph_tiled(m, config=config, block_px=64)
    result = tj.build_graph(m, config=config)
    if graph.prunes:
        assert tiled.graph_store is None
        assert_same_networkx(tiled.graph, result.graph)
    else:
        assert_same_graph(tiled, result)


def test_whole_graph_stages_beyond_the_memory_available_are_refused_naming_the_option(
    monkeypatch,
):
    """Merging junction clusters (the whole pixel graph) and pruning (a networkx graph)
    hold the whole graph at once, not a block's share: where the memory available cannot
    hold it, the build is refused naming the option and the counts, before that stage; with
    the memory known to suffice (or unknown, off Linux) the same build gives
    ``build_graph``'s graph."""
    from topojax import _cpus as cpus
    from topojax.graph.store import NX_BYTES_PER_ELEMENT
    from topojax.outofcore.build import MERGE_BYTES_PER_SKELETON_PX

    m = paper_map("intel")
    n_px = int(np.count_nonzero(tj.build_graph(m, config=SMALL).skeleton))
    merged = replace(SMALL, graph=GraphConfig(merge_junction_clusters=True))
    pruned = replace(SMALL, graph=GraphConfig(min_spur_m=0.5))
    store = tj.build_graph_tiled(m, config=SMALL, block_px=128).graph_store
    nx_need = NX_BYTES_PER_ELEMENT * (store.n_nodes + store.n_edges)
    for config, need, words in (
        (merged, MERGE_BYTES_PER_SKELETON_PX * n_px, f"pixel graph of {n_px:,} skeleton"),
        (
            pruned,
            nx_need,
            "to prune (config.graph's min_clearance_m, min_spur_m, min_component_m), the "
            f"networkx graph of {store.n_nodes:,} vertices",
        ),
    ):
        monkeypatch.setattr(cpus, "available_memory_bytes", lambda need=need: need - 1)
        with pytest.raises(MemoryError, match="build_graph_tiled: ") as error:
            tj.build_graph_tiled(m, config=config, block_px=128)
        assert words in str(error.value)
        assert ("merge_junction_clusters" if config is merged else "min_spur_m") in str(error.value)
        for available in (need, None):
            monkeypatch.setattr(cpus, "available_memory_bytes", lambda a=available: a)
            tiled = tj.build_graph_tiled(m, config=config, block_px=128)
            if config is pruned:
                assert_same_networkx(tiled.graph, tj.build_graph(m, config=config).graph)
            else:
                assert_same_graph(tiled, tj.build_graph(m, config=config))


def test_shared_slam_map_streamed_from_its_pgm(shared_data):
    path = shared_data / "maps" / "slam_pgm" / "edmonton_0.06.pgm"
    source = tj.open_tiled_map(path)
    assert type(source.reader).__name__ == "_PgmReader"
    tiled = tj.build_graph_tiled(source, config=SMALL, block_px=256)
    assert_same_graph(tiled, tj.build_graph(tj.load_map(path), config=SMALL))


def test_synthetic_floor_plan():
    plan = floor_plan(4, size_m=(90.0, 110.0)).occupancy
    tiled = tj.build_graph_tiled(plan, block_px=512)
    assert tiled.blocks == 20
    assert_same_graph(tiled, tj.build_graph(plan))


# ----------------------------------------------------------------------- sources


@pytest.mark.parametrize("form", ["folder", "zarr", "pgm", "yaml"])
def test_stored_maps_give_the_loaded_maps_graph(tmp_path, form):
    m = paper_map("intel")
    if form in ("pgm", "yaml"):
        tj.save_map(m, tmp_path / "m.yaml")
        path = tmp_path / ("m.pgm" if form == "pgm" else "m.yaml")
    else:
        pytest.importorskip("zarr") if form == "zarr" else None
        path = tj.save_tiled_map(m, tmp_path / "m", tile_px=100, format=form)
    source = tj.open_tiled_map(path)
    loaded = tj.load_map(tmp_path / "m.yaml") if form in ("pgm", "yaml") else m
    whole = source.occupancy()
    for name in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(whole, name), getattr(loaded, name)), name
    tiled = tj.build_graph_tiled(source, config=SMALL, block_px=128)
    result = tj.build_graph(loaded, config=SMALL)
    store = tiled.graph_store
    assert store.attrs["source"] == str(path)
    store.attrs["source"] = result.graph_store.attrs.get("source")
    assert_same_graph(tiled, result)


def test_load_map_maps_a_binary_pgm_instead_of_reading_it(tmp_path):
    from topojax.maps.files import _read_pixels
    from topojax.maps.pnm import read_image

    tj.save_map(paper_map("office"), tmp_path / "m.yaml")
    pixels, full, _ = _read_pixels(tmp_path / "m.pgm")
    assert isinstance(pixels, np.memmap) and full == 255
    assert np.array_equal(pixels, read_image(tmp_path / "m.pgm")[0])


def test_tile_folder_layout_and_windows(tmp_path):
    grid = np.full((300, 500), -1, np.int8)
    grid[100:200, 50:450] = 0
    grid[140:160, 60:440] = 100
    path = tj.save_tiled_map(grid, tmp_path / "g", tile_px=128)
    assert (path / TILE_INDEX).is_file()
    assert (path / "r00002_c00003.npy").is_file()
    source = tj.open_tiled_map(path, resolution_m=0.1)
    assert source.kind == "grid" and source.resolution_m == 0.1
    want = tj.OccupancyMap.from_array(grid, resolution_m=0.1)
    assert np.array_equal(source.occupied(90, 290, 100, 400), want.occupied[90:290, 100:400])
    assert np.array_equal(source.values(120, 140, 0, 500), grid[120:140])


@pytest.mark.parametrize("yaw", [0.0, 0.7])
def test_a_windows_occupancy_map_places_its_pixels_where_the_whole_map_has_them(yaw):
    grid = np.full((60, 80), 0, np.int8)
    grid[20:30, 10:70] = 100
    source = TiledMap.from_array(grid, resolution_m=0.1, origin=(-3.0, 2.5, yaw))
    window = source.occupancy(12, 50, 7, 61)
    rows, cols = np.mgrid[0:38, 0:54]
    got = window.pixel_to_world(rows, cols)
    want = source.pixel_to_world(rows + 12, cols + 7)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert np.array_equal(window.occupied, grid[12:50, 7:61] == 100)
    assert source.occupancy().origin == source.origin


def test_a_memory_mapped_array_goes_to_a_worker_as_its_file_not_its_pixels(tmp_path):
    """Each block task of an executor pickles the map: a ``numpy.memmap`` given to
    ``TiledMap.from_array`` is opened again from its file there, as a PGM is, rather than
    copied whole into every task (a map larger than memory could not be sent at all)."""
    import pickle

    grid = np.full((600, 700), 254, np.uint8)
    grid[::7] = 0
    np.save(tmp_path / "m.npy", grid)
    mapped = np.load(tmp_path / "m.npy", mmap_mode="r")
    for array, want in ((mapped, grid), (mapped[50:580, 30:], grid[50:580, 30:])):
        source = TiledMap.from_array(array, resolution_m=0.1)
        sent = pickle.dumps(source)
        assert len(sent) < 20_000, len(sent)
        back = pickle.loads(sent)
        assert back.shape == want.shape
        assert np.array_equal(back.values(0, want.shape[0], 0, want.shape[1]), want)
    # an array in memory has no file: its pixels go with it
    in_memory = pickle.loads(pickle.dumps(TiledMap.from_array(grid)))
    assert np.array_equal(in_memory.values(0, 600, 0, 700), grid)


def test_a_png_path_is_read_whole():
    tiled = tj.build_graph_tiled("topojax/data/a_scan.png", config=SMALL, block_px=256)
    assert_same_graph(tiled, tj.build_graph("topojax/data/a_scan.png", config=SMALL))


def test_an_executors_blocks_are_released_once_gathered(monkeypatch):
    import concurrent.futures as cf
    import gc
    import weakref

    from topojax.outofcore import build

    seen, alive = [], []
    add, finish = build._Skeleton.add, build._Skeleton.finish

    def tracked_add(self, piece):
        seen.append(weakref.ref(piece))
        add(self, piece)

    def counted_finish(self):
        gc.collect()
        alive.append(sum(ref() is not None for ref in seen))
        return finish(self)

    monkeypatch.setattr(build._Skeleton, "add", tracked_add)
    monkeypatch.setattr(build._Skeleton, "finish", counted_finish)
    m = paper_map("intel")
    with cf.ThreadPoolExecutor(2) as pool:
        result = tj.build_graph_tiled(m, config=SMALL, block_px=128, executor=pool)
    band = -(-m.shape[1] // 128)
    assert len(seen) == result.blocks > band
    assert alive == [band]  # only the last band of blocks, not every block


def test_dask_client_runs_the_blocks():
    distributed = pytest.importorskip("dask.distributed")
    m = paper_map("office")
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1) as client:
        tiled = tj.build_graph_tiled(m, config=SMALL, block_px=128, executor=client)
    assert_same_graph(tiled, tj.build_graph(m, config=SMALL))


def test_memory_budget_sets_the_block_side():
    small, large = (
        block_px_for_budget(64, PipelineConfig()),
        block_px_for_budget(1024, PipelineConfig()),
    )
    assert small % 256 == 0 and large % 256 == 0
    assert 256 <= small < large
    # below one tile's window the budget cannot be kept: refused, not exceeded
    wide = PipelineConfig(distance=DistanceConfig(sigma_px=280.0))
    assert block_px_for_budget(122, wide) == 256
    with pytest.raises(
        ValueError,
        match=r"memory_budget_mb: expected at least 121.5 MB.*"
        r"256 px tile with a halo of 1024 px.*received 64",
    ):
        block_px_for_budget(64, wide)
    # a budget near the largest float sizes blocks as large as it allows, rather than
    # failing on its overflowed byte count (inf pixels: "cannot convert float NaN")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # more than the memory available
        huge = block_px_for_budget(1e308, PipelineConfig())
    assert huge % 256 == 0 and huge > large


def test_a_map_smaller_than_the_least_window_needs_only_its_own_window():
    """A block's window is cut at the map's edges, so a map smaller than one tile and its
    halos needs only its own pixels' budget: tiles larger than the map are accepted with
    a budget that holds the map, and the least budget refused names this map's window."""
    m = paper_map("intel")  # 708 x 763 px
    big_tiles = PipelineConfig(tile_px=4096)  # a window of 12288 px a side, uncut
    assert block_px_for_budget(13, big_tiles, shape=m.shape) == 4096
    tiled = tj.build_graph_tiled(m, config=big_tiles, memory_budget_mb=13)
    assert tiled.blocks == 1 and tiled.largest_window_px == m.shape
    assert_same_graph(tiled, tj.build_graph(m, config=big_tiles))
    with pytest.raises(
        ValueError,
        match=r"memory_budget_mb: expected at least 12.4 MB, what the smallest block takes "
        r"\(one 4096 px tile with a halo of 4096 px on each side, the distance window's "
        r"reach, a window of 708 x 763 px cut at this map's edges\), received 12$",
    ):
        tj.build_graph_tiled(m, config=big_tiles, memory_budget_mb=12)


def test_a_memory_budget_above_the_memory_available_is_warned_of_once(monkeypatch):
    """A budget above the memory available sizes blocks that may not fit: a warning
    names the budget and the memory (not a refusal: what is available changes).  At or
    below it, or where it is not known, nothing is said."""
    import topojax.outofcore.build as build

    monkeypatch.setattr(build, "available_memory_bytes", lambda: 100 * 2**20)
    with pytest.warns(UserWarning) as caught:
        assert block_px_for_budget(512, PipelineConfig()) % 256 == 0
    assert [str(w.message) for w in caught] == [
        "memory_budget_mb: 512 MB (512.0 MiB) is more than the 100.0 MiB of memory "
        "available; blocks sized to it may not fit (a smaller budget gives smaller blocks)"
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tj.build_graph_tiled(np.zeros((64, 64), bool), config=SMALL, memory_budget_mb=200)
    assert ["memory_budget_mb: 200 MB" in str(w.message) for w in caught] == [True]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        block_px_for_budget(100, PipelineConfig())  # all that is available
        monkeypatch.setattr(build, "available_memory_bytes", lambda: None)  # not Linux
        block_px_for_budget(10**6, PipelineConfig())


# ----------------------------------------------------------------------- bad arguments


def test_a_bad_map_yaml_is_named_when_opened(tmp_path):
    img = np.full((6, 8), 254, np.uint16)
    header = b"P5\n8 6\n65535\n"
    (tmp_path / "m.pgm").write_bytes(header + (img * 257).astype(">u2").tobytes())
    common = "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
    (tmp_path / "raw.yaml").write_text(common + "mode: raw\n")
    (tmp_path / "swap.yaml").write_text(common + "occupied_thresh: 0.1\nfree_thresh: 0.9\n")
    for name, needle in (("raw", "mode='raw'"), ("swap", "free_thresh, occupied_thresh")):
        path = tmp_path / f"{name}.yaml"
        with pytest.raises(ValueError, match=f"map YAML {path}: {needle}"):
            tj.open_tiled_map(path)
        with pytest.raises(ValueError, match=f"map YAML {path}: {needle}"):
            tj.build_graph_tiled(path)


def test_a_pgm_sample_above_its_maxval_is_named_when_read(tmp_path):
    """A window holding a sample above the PGM's maxval indexed past the classification
    table (an IndexError); load_map refuses the same file by name."""
    for name, maxval, dtype, top in (("m15.pgm", 15, np.uint8, 200), ("k.pgm", 1000, ">u2", 1536)):
        img = np.full((4, 6), maxval, dtype=dtype)
        img[3, 5] = top
        path = tmp_path / name
        path.write_bytes(f"P5\n6 4\n{maxval}\n".encode() + img.tobytes())
        tiled = tj.open_tiled_map(path)
        assert tiled.codes(0, 3, 0, 6).tolist() == [[0] * 6] * 3  # the rest reads
        with pytest.raises(
            ValueError,
            match=f"map {path}, rows 2:4, cols 0:6: image: "
            f"expected intensities 0..{maxval} .* received a pixel of {top}",
        ):
            tiled.codes(2, 4, 0, 6)
        with pytest.raises(ValueError, match=f"{name} has pixel values above its PGM maxval"):
            tj.load_map(path)


def test_a_pgm_that_changes_after_it_was_opened_is_refused(tmp_path):
    """A PGM rewritten after it was opened is refused, not read with the header read
    then: in the old layout (a larger file: another map's pixels, silently) or not at
    all (a shorter one: numpy's "mmap length is greater than file size"); rewritten
    while mapped, its windows would mix two maps."""
    import os

    img = np.array(paper_map("intel").to_image())
    path = tmp_path / "m.pgm"

    def write(a) -> None:
        path.write_bytes(f"P5\n{a.shape[1]} {a.shape[0]}\n255\n".encode() + a.tobytes())

    for other in (np.pad(img, ((0, 0), (0, 40))), img[:, :300]):  # another size
        write(img)
        source = tj.open_tiled_map(path)
        write(other)
        with pytest.raises(ValueError, match=rf"^map {path}: expected the PGM opened \(763 x "):
            tj.build_graph_tiled(source, config=SMALL, block_px=128)
    write(img)
    source = tj.open_tiled_map(path)
    assert source.values(0, 2, 0, 2).shape == (2, 2)  # mapped
    other = img.copy()
    other[10:60, 10:200] = 0  # the same size, other pixels
    write(other)
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    with pytest.raises(ValueError, match=r"unchanged, but it changed while it was read; open"):
        source.codes(0, 128, 0, 128)
    tiled = tj.build_graph_tiled(tj.open_tiled_map(path), config=SMALL, block_px=128)
    assert_same_graph(tiled, tj.build_graph(tj.load_map(path), config=SMALL))


def test_a_pgm_rewritten_between_the_blocks_of_workers_is_refused(tmp_path, monkeypatch):
    """A worker's copy of the map (pickled, as a process pool or a Dask worker gets it)
    holds the file's signature from when the map was opened: a PGM rewritten (the same
    size) between two blocks is refused, not read into a graph mixed from two maps."""
    import concurrent.futures as cf
    import os
    import pickle

    from topojax.maps import tiled as tiled_module

    img = np.array(paper_map("intel").to_image())
    path = tmp_path / "m.pgm"

    def write(a) -> None:
        path.write_bytes(f"P5\n{a.shape[1]} {a.shape[0]}\n255\n".encode() + a.tobytes())
        st = path.stat()  # a later modification time, on a coarse-clock file system too
        os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))

    class CopyingPool(cf.ThreadPoolExecutor):
        """Each task gets its own copy of its arguments, as a worker process does."""

        def submit(self, fn, /, *args, **kwargs):
            return super().submit(fn, *pickle.loads(pickle.dumps(args)), **kwargs)

    other = img.copy()
    other[10:300, 10:300] = 0  # the same size, other pixels
    read, reads = tiled_module._PgmReader.read, []

    def read_then_rewrite(self, *box):
        out = read(self, *box)
        reads.append(box)
        if len(reads) == 1:
            write(other)
        return out

    monkeypatch.setattr(tiled_module._PgmReader, "read", read_then_rewrite)
    write(img)
    with (
        CopyingPool(1) as pool,
        pytest.raises(
            ValueError,
            match=rf"^map {path}: expected the PGM opened \(763 x 708 .* unchanged, but ",
        ),
    ):
        tj.build_graph_tiled(tj.open_tiled_map(path), config=SMALL, block_px=128, executor=pool)
    assert len(reads) == 1


def test_bad_arguments_name_the_parameter(tmp_path):
    m = paper_map("intel")
    with pytest.raises(ValueError, match="block_px: expected a multiple of config.tile_px"):
        tj.build_graph_tiled(m, block_px=300)
    with pytest.raises(ValueError, match="block_px"):
        tj.build_graph_tiled(m, block_px=0)
    with pytest.raises(ValueError, match="memory_budget_mb"):
        tj.build_graph_tiled(m, memory_budget_mb=0)
    # with block_px given the budget sizes nothing, but a bad one is refused, not ignored
    for budget, error in ((-64, ValueError), (float("nan"), ValueError), ("64", TypeError)):
        with pytest.raises(error, match=r"^memory_budget_mb: expected a .*number of megabytes"):
            tj.build_graph_tiled(m, block_px=256, memory_budget_mb=budget)
    with pytest.raises(TypeError, match="executor"):
        tj.build_graph_tiled(m, executor="threads")
    with pytest.raises(ValueError, match=r"^threads: expected an int >= 1"):
        tj.build_graph_tiled(m, threads=0, config=SMALL)
    with pytest.raises(TypeError, match="source"):
        tj.build_graph_tiled([[0, 1], [1, 0]])
    with pytest.raises(TypeError, match="config"):
        tj.build_graph_tiled(m, config=SMALL.distance)
    with pytest.raises(FileNotFoundError, match="path"):
        tj.open_tiled_map(tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="^source: map not found: .*missing"):
        tj.build_graph_tiled(tmp_path / "missing")  # named as open_tiled_map's ``path``
    (tmp_path / "maps").mkdir()  # a folder of map files is no tiled map: named ``source``
    with pytest.raises(ValueError, match="^source: expected a tile folder .*received .*maps"):
        tj.build_graph_tiled(tmp_path / "maps")
    (tmp_path / "m.png").write_bytes(b"")
    with pytest.raises(ValueError, match="path: expected a tile folder"):
        tj.open_tiled_map(tmp_path / "m.png")
    for name in ("folder.pgm", "folder.yaml"):  # a folder, whatever its name ends with
        (tmp_path / name).mkdir()
        with pytest.raises(ValueError, match=f"path: expected a tile folder.*{name}"):
            tj.open_tiled_map(tmp_path / name)
    with pytest.raises(ValueError, match="window"):
        TiledMap.from_occupancy(m).codes(0, 800, 0, 10)
    # a fractional bound is refused, not truncated (rows 1.5:3 read as 1:3), and so is
    # None, not left to fail in a comparison
    tiled = TiledMap.from_occupancy(m)
    with pytest.raises(TypeError, match=r"^r0: expected an int, received float 1\.5"):
        tiled.codes(1.5, 3, 0, 3)
    with pytest.raises(TypeError, match="^c1: expected an int, received NoneType"):
        tiled.values(0, 3, 0, None)
    with pytest.raises(TypeError, match="^r1: expected an int, received bool"):
        tiled.occupied(0, True, 0, 3)
    with pytest.raises(TypeError, match="^occupancy: expected an OccupancyMap, received ndarray"):
        TiledMap.from_occupancy(np.zeros((4, 4), bool))
    # a window too small for an OccupancyMap is named as the window, not as
    # OccupancyMap's own shape
    with pytest.raises(ValueError, match=r"^window: expected at least 2 x 2 .*rows 0:0, cols 1:5"):
        tiled.occupancy(0, 0, 1, 5)
    # a reader that is not one is named, not left to an AttributeError on its shape
    with pytest.raises(TypeError, match=r"^reader: expected an object with shape, dtype and read"):
        TiledMap(np.zeros((4, 4), np.uint8).tolist())
    # a white beyond the image's values is refused, rather than asking for a lookup table
    # as long (Maximum allowed size exceeded) at the first window read
    reader = TiledMap.from_array(np.zeros((4, 4), np.uint8)).reader
    assert TiledMap(reader, full_scale=100).full_scale == 100
    with pytest.raises(ValueError, match=r"^full_scale: expected an int from 1 to 255 for a uint8"):
        TiledMap(reader, full_scale=10**30)
    # a source that is no path or name is refused, not kept as its str()
    with pytest.raises(TypeError, match=r"^source: expected a str, an os.PathLike or None"):
        TiledMap(reader, source=True)
    # out_dir that is not a path: named, not pathlib's TypeError
    with pytest.raises(TypeError, match=r"^out_dir: expected a path \(str or os.PathLike\)"):
        tj.build_graph_tiled(m, out_dir=3)
    # an array of the wrong type or shape is named as the caller gave it, not as the
    # TiledMap's internal reader
    floats = np.zeros((64, 64), np.float32)
    with pytest.raises(TypeError, match=r"^array: expected .*uint8 .*received float32"):
        TiledMap.from_array(floats)
    with pytest.raises(TypeError, match=r"^source: expected .*uint8 .*received float32"):
        tj.build_graph_tiled(floats)
    with pytest.raises(TypeError, match=r"^tiled: expected .*uint8 .*received int16"):
        tj.save_tiled_map(floats.astype(np.int16), tmp_path / "i16")
    with pytest.raises(ValueError, match=r"^source: expected a 2-D .*received shape \(8, 8, 3\)"):
        tj.build_graph_tiled(np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(ValueError, match=r"^source: expected .*at least 2 x 2 pixels"):
        tj.build_graph_tiled(np.zeros((1, 5), np.uint8))
    with pytest.raises(ValueError, match="format"):
        tj.save_tiled_map(m, tmp_path / "x", format="tiff")
    # a tile of one pixel is a file (or Zarr chunk) per pixel: thousands of times the
    # map on disk; refused before anything is written
    for side in (1, 15):
        with pytest.raises(ValueError, match=rf"tile_px: expected an int >= 16, received {side}"):
            tj.save_tiled_map(m, tmp_path / "one", tile_px=side)
        assert not (tmp_path / "one").exists()


def test_bad_threads_are_refused_before_any_block(monkeypatch):
    """Not deep in the first block's kernels, or in an executor's worker."""
    import topojax.outofcore.build as tiled_build

    def no_block(*args, **kwargs):
        raise AssertionError("a block was computed")

    monkeypatch.setattr(tiled_build, "block_piece", no_block)
    for threads, error in ((0, ValueError), (-1, ValueError), ("2", TypeError)):
        with pytest.raises(error, match=r"^threads: expected an int >= 1"):
            tj.build_graph_tiled(paper_map("intel"), threads=threads, config=SMALL)


def test_a_process_pool_that_forks_its_workers_is_refused_before_any_block(monkeypatch):
    """Each block runs JAX in the worker: one forked from this process (which has JAX's
    threads) waited for ever on one of their locks, so the build never ended."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    import topojax.outofcore.build as tiled_build

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork start method here")

    def no_block(*args, **kwargs):
        raise AssertionError("a block was computed")

    monkeypatch.setattr(tiled_build, "block_piece", no_block)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as pool:
        with pytest.raises(ValueError, match=r"^executor: expected a process pool .*forkserver"):
            tj.build_graph_tiled(paper_map("a_scan"), config=SMALL, executor=pool)


def test_a_tile_index_with_bad_metadata_is_named(tmp_path):
    import json

    folder = tj.save_tiled_map(paper_map("intel"), tmp_path / "m", tile_px=256)
    index = json.loads((folder / TILE_INDEX).read_text())
    for key, value, error in (("free_thresh", 0.9, ValueError), ("origin", "zero", TypeError)):
        (folder / TILE_INDEX).write_text(json.dumps({**index, key: value}))
        with pytest.raises(error, match=rf"^path: {folder / TILE_INDEX}: .*{key}"):
            tj.open_tiled_map(folder)


@pytest.mark.parametrize("form", ["folder", "zarr"])
def test_a_bad_override_is_named_as_the_callers_not_the_stored_files(tmp_path, form):
    if form == "zarr":
        pytest.importorskip("zarr")
    grid = np.zeros((40, 40), np.int8)
    path = tj.save_tiled_map(grid, tmp_path / "g", tile_px=16, format=form)
    for key, value in (("negate", True), ("resolution_m", -1.0), ("origin", (1.0, 2.0))):
        with pytest.raises(ValueError, match=key) as info:
            tj.open_tiled_map(path, **{key: value})
        assert str(path) not in str(info.value), key
    with pytest.raises(
        TypeError,
        match=r"expected keyword arguments from .*resolution_m.*"
        r"received \['bogus'\]",
    ):
        tj.open_tiled_map(path, bogus=1)


def test_a_tile_folder_whose_save_did_not_finish_says_so(tmp_path):
    """save_tiled_map writes the index last: a folder of tiles without it is an
    interrupted save, not an unknown form, and saving again needs an empty folder."""
    folder = tj.save_tiled_map(paper_map("intel"), tmp_path / "m", tile_px=256)
    (folder / TILE_INDEX).unlink()
    with pytest.raises(ValueError, match=rf"^source: {folder} holds 9 tiles but no {TILE_INDEX}"):
        tj.build_graph_tiled(folder)
    with pytest.raises(ValueError, match="did not finish"):
        tj.save_tiled_map(paper_map("intel"), folder, tile_px=256)


def test_a_tiled_map_of_an_occupancy_map_is_saved_with_its_unknown_pixels(tmp_path):
    img = np.full((40, 50), 254, np.uint8)
    img[:, :3], img[10:20, 10:30] = 0, 205
    m = tj.OccupancyMap.from_array(img, resolution_m=0.1, origin=(1.0, 2.0, 0.0))
    tj.save_tiled_map(TiledMap.from_occupancy(m), tmp_path / "t", tile_px=16)
    back = tj.open_tiled_map(tmp_path / "t").occupancy()
    for name in ("occupied", "free", "unknown"):
        assert np.array_equal(getattr(back, name), getattr(m, name)), name
    assert (back.resolution_m, back.origin) == (m.resolution_m, m.origin)


def test_a_zarr_save_leaves_a_folder_of_other_files_alone(tmp_path):
    pytest.importorskip("zarr")
    folder = tmp_path / "maps"
    folder.mkdir()
    (folder / "notes.txt").write_text("keep me")
    img = np.full((8, 8), 254, np.uint8)
    with pytest.raises(ValueError, match="empty or new folder or a Zarr array"):
        tj.save_tiled_map(img, folder, format="zarr")
    assert (folder / "notes.txt").read_text() == "keep me"
    tj.save_tiled_map(img, tmp_path / "z", format="zarr")
    tj.save_tiled_map(img[:4], tmp_path / "z", format="zarr")  # a Zarr array is replaced
    assert tj.open_tiled_map(tmp_path / "z").shape == (4, 8)
    (tmp_path / "f").touch()
    with pytest.raises(NotADirectoryError, match="path: "):
        tj.save_tiled_map(img, tmp_path / "f", format="zarr")


def test_zarr_missing_names_the_extra(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_zarr(name, *args, **kwargs):
        if name == "zarr":
            raise ImportError("no zarr here")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_zarr)
    with pytest.raises(ImportError, match=r"topojax\[zarr\]"):
        tj.save_tiled_map(np.zeros((4, 4), np.uint8) + 254, tmp_path / "z", format="zarr")


def _tile_folder(tmp_path):
    grid = np.full((300, 280), 254, np.uint8)
    grid[100:110, :] = 0
    return tj.save_tiled_map(grid, tmp_path / "g", tile_px=128)  # 3 x 3 tiles


@pytest.mark.parametrize(
    ("damage", "error", "needle"),
    [
        # a tile of the wrong size would leave uninitialised memory in the window
        (
            lambda p: np.save(p / "r00001_c00001.npy", np.zeros((10, 10), np.uint8)),
            ValueError,
            r"r00001_c00001.npy: expected a uint8 array of 128 x 128 .* \(10, 10\)",
        ),
        # a float tile would be cast silently
        (
            lambda p: np.save(p / "r00002_c00000.npy", np.full((44, 128), 0.7)),
            ValueError,
            "expected a uint8 array of 44 x 128 pixels .* received a float64",
        ),
        (
            lambda p: (p / "r00000_c00002.npy").write_bytes(b"not an array"),
            ValueError,
            r"r00000_c00002.npy is not a .npy array \(expected a file that begins with the "
            r".npy magic string b'\\x93NUMPY', received one that begins with b'not an'\)$",
        ),
        # a 0-byte tile (a disk that filled up): numpy raises a bare EOFError for it
        (
            lambda p: (p / "r00001_c00000.npy").write_bytes(b""),
            ValueError,
            "r00001_c00000.npy is not a .npy array",
        ),
    ],
)
def test_a_damaged_tile_is_named_when_read(tmp_path, damage, error, needle):
    path = _tile_folder(tmp_path)
    damage(path)
    source = tj.open_tiled_map(path)
    with pytest.raises(error, match=needle):
        source.values(0, 300, 0, 280)
    with pytest.raises(error, match=needle):
        tj.build_graph_tiled(source)


def test_a_tile_index_that_disagrees_with_its_tiles_is_refused_on_opening(tmp_path):
    import json

    path = _tile_folder(tmp_path)
    index = json.loads((path / TILE_INDEX).read_text())
    # a shape far larger than the tiles present (else blocks are planned until memory
    # runs out)
    (path / TILE_INDEX).write_text(json.dumps({**index, "shape": [10**9, 10**9]}))
    with pytest.raises(ValueError, match="expected 61035156250000 tile files, found 9"):
        tj.open_tiled_map(path)
    # and a tile side as large: one tile file, as many as the folder holds, so the count
    # cannot refuse it; the tile's own shape does, before a build plans 10^10 blocks
    for f in path.glob("r*_c*.npy"):
        if f.name != "r00000_c00000.npy":
            f.unlink()
    (path / TILE_INDEX).write_text(json.dumps({**index, "shape": [10**8] * 2, "tile_px": 10**8}))
    with pytest.raises(
        ValueError, match=r"r00000_c00000.npy: expected a uint8 array of 100000000 x 100000000 "
    ):
        tj.open_tiled_map(path)
    path = _tile_folder(tmp_path / "again")
    for bad, needle in (
        ({"shape": [300]}, "shape: expected two positive integers"),
        ({"tile_px": 0}, "tile_px: expected a positive integer"),
        ({"dtype": "float32"}, "dtype: expected an integer or bool type name"),
        ({"version": 2}, "expected version 1 of the tile index, received 2"),
        ({"version": None}, "expected version 1 of the tile index, received None"),
    ):
        (path / TILE_INDEX).write_text(json.dumps({**index, **bad}))
        with pytest.raises(ValueError, match=needle):
            tj.open_tiled_map(path)
    (path / TILE_INDEX).write_text(json.dumps(index))
    (path / "r00001_c00002.npy").rename(path / "r00003_c00000.npy")
    with pytest.raises(ValueError, match="tile r00001_c00002.npy of the 3 x 3 tiles is missing"):
        tj.open_tiled_map(path)
    (path / TILE_INDEX).write_text("{not json")
    with pytest.raises(ValueError, match="is not JSON"):
        tj.open_tiled_map(path)


def test_a_zarr_array_missing_a_chunk_is_refused(tmp_path, monkeypatch):
    """Zarr reads a missing chunk as 0, an obstacle: a deleted chunk, or a save that
    stopped, is refused, not built into another graph without any error."""
    pytest.importorskip("zarr")
    img = np.full((300, 280), 254, np.uint8)  # chunks of one value are written all the same
    img[100:110, :] = 0
    path = tj.save_tiled_map(img, tmp_path / "m.zarr", format="zarr", tile_px=128)
    tj.open_tiled_map(path)
    (path / "c" / "1" / "1").unlink()
    with pytest.raises(ValueError, match=r"all its 9 chunks but holds 8: the save did not"):
        tj.build_graph_tiled(path)
    import topojax.maps.tiled as tiled

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tiled.TiledMap, "values", stop)
    with pytest.raises(KeyboardInterrupt):
        tj.save_tiled_map(img, tmp_path / "cut.zarr", format="zarr", tile_px=128)
    with pytest.raises(ValueError, match=r"all its 9 chunks but holds 0"):
        tj.open_tiled_map(tmp_path / "cut.zarr")


def test_an_empty_pgm_is_named_as_empty(tmp_path):
    """Not "not a binary PGM": the file has nothing in it, as load_map says too."""
    empty = tmp_path / "map.pgm"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match=r"path: .*map\.pgm is empty \(0 bytes\)"):
        tj.open_tiled_map(empty)
    with pytest.raises(ValueError, match=r"map image .*map\.pgm is empty \(0 bytes\)"):
        tj.load_map(empty)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("name", ["map.pgm", "map.yaml"])
def test_a_named_pipe_is_refused_as_one_not_read(tmp_path, name):
    """open_tiled_map refuses a FIFO by name, as load_map does, rather than wait on it for a
    writer. A writer here sends a small map, so that a reading of the pipe would end."""
    fifo = tmp_path / name
    os.mkfifo(fifo)
    pgm = b"P5\n4 4\n255\n" + bytes([254] * 16)

    def write():
        with open(fifo, "wb") as out:  # waits for a reader
            out.write(pgm if name.endswith(".pgm") else b"image: x.pgm\nresolution: 0.1\n")

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    try:
        with pytest.raises(ValueError, match=rf"path: .*{name} is a FIFO; expected a "):
            tj.open_tiled_map(fifo)
    finally:  # a reader that takes nothing lets the writer's open return
        fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        writer.join()
        os.close(fd)
