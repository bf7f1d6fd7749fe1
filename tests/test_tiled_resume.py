"""A stopped ``build_graph_tiled`` goes on from the blocks it finished (``resume=True``):
the same graph as one uninterrupted build, only the missing or changed blocks computed
again, and never the blocks of another build."""

from __future__ import annotations

import concurrent.futures as cf

import numpy as np
import pytest
from test_tiled import SMALL, assert_same_graph, paper_map

import topojax as tj
import topojax.outofcore.build as tiled_build
from topojax.config import DistanceConfig, PipelineConfig
from topojax.outofcore.checkpoint import BLOCKS_FOLDER

BLOCK = 128  # the office map (727 x 1234) in 6 x 10 blocks
OTHER = PipelineConfig(distance=DistanceConfig.from_pixels(sigma_px=12.0), tile_px=64)


def stop_after(monkeypatch, n_blocks: int) -> list:
    """Make the block computation stop (Ctrl-C) when block ``n_blocks + 1`` starts;
    returns the list of the boxes computed, call by call."""
    real = tiled_build._block_task
    done: list = []

    def task(tiled, box, *args):
        if len(done) == n_blocks:
            raise KeyboardInterrupt
        done.append(box)
        return real(tiled, box, *args)

    monkeypatch.setattr(tiled_build, "_block_task", task)
    return done


def stopped_build(monkeypatch, m, out, n_blocks: int) -> list:
    """Build ``m`` into ``out`` and stop it (Ctrl-C) once ``n_blocks`` blocks are done;
    returns their boxes."""
    done = stop_after(monkeypatch, n_blocks)
    with pytest.raises(KeyboardInterrupt):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out)
    monkeypatch.undo()
    return done


def test_a_stopped_build_goes_on_where_it_stopped(tmp_path, monkeypatch):
    m = paper_map("office")
    out = tmp_path / "graph"
    done = stop_after(monkeypatch, 7)
    with pytest.raises(KeyboardInterrupt):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out)
    assert len(list((out / BLOCKS_FOLDER).glob("block_*.npz"))) == 7
    monkeypatch.undo()
    computed = stop_after(monkeypatch, 10**6)
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    assert res.blocks_reused == 7
    assert not set(computed) & set(done)
    assert len(computed) == res.blocks - 7
    assert_same_graph(res, tj.build_graph(m, config=SMALL))
    # the graph is written: its folder holds the store and no blocks
    assert not (out / BLOCKS_FOLDER).exists()
    assert tj.load_graph_store(out).n_edges == res.graph_store.n_edges


def test_a_block_whose_window_changed_is_computed_again(tmp_path, monkeypatch):
    m = paper_map("office")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 12)
    # an obstacle pixel in the first block: the windows that hold it are computed again
    occupied = np.array(m.occupied)
    free = np.array(m.free)
    occupied[40, 60], free[40, 60] = True, False
    changed = tj.OccupancyMap(
        occupied=occupied,
        free=free,
        unknown=np.array(m.unknown),
        resolution_m=m.resolution_m,
        origin=m.origin,
    )
    computed = stop_after(monkeypatch, 10**6)
    res = tj.build_graph_tiled(changed, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    assert 0 < res.blocks_reused < 12
    assert (0, BLOCK, 0, BLOCK) in computed
    assert_same_graph(res, tj.build_graph(changed, config=SMALL))


def test_blocks_in_a_pool_are_kept_and_reused(tmp_path, monkeypatch):
    m = paper_map("intel")
    out = tmp_path / "graph"
    with cf.ThreadPoolExecutor(2) as pool:
        first = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, executor=pool)
    assert first.blocks_reused == 0
    # the graph stage stops: every block is kept, none is computed on resuming
    monkeypatch.setattr(tiled_build, "_graph", lambda *a: (_ for _ in ()).throw(MemoryError))
    with pytest.raises(MemoryError):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out)
    monkeypatch.undo()
    computed = stop_after(monkeypatch, 10**6)
    with cf.ThreadPoolExecutor(2) as pool:
        res = tj.build_graph_tiled(
            m, config=SMALL, block_px=BLOCK, out_dir=out, executor=pool, resume=True
        )
    assert computed == [] and res.blocks_reused == res.blocks
    assert_same_graph(res, tj.build_graph(m, config=SMALL))


def test_blocks_of_another_build_are_refused_and_a_new_build_clears_them(tmp_path, monkeypatch):
    m = paper_map("office")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 3)
    with pytest.raises(ValueError, match=r"^resume: .* another build \(block_px: 128, here 64\)"):
        tj.build_graph_tiled(m, config=SMALL, block_px=64, out_dir=out, resume=True)
    with pytest.raises(ValueError, match=r"^resume: .* another build \(distance: "):
        tj.build_graph_tiled(m, config=OTHER, block_px=BLOCK, out_dir=out, resume=True)
    with pytest.raises(ValueError, match=r"^resume: .* another build \(shape: "):
        tj.build_graph_tiled(
            paper_map("intel"), config=SMALL, block_px=BLOCK, out_dir=out, resume=True
        )
    # without resume the old blocks go first; a file of another program stays
    (out / BLOCKS_FOLDER / "notes.txt").write_text("mine")
    computed = stop_after(monkeypatch, 10**6)
    res = tj.build_graph_tiled(m, config=SMALL, block_px=64, out_dir=out)
    assert res.blocks_reused == 0 and len(computed) == res.blocks
    assert sorted(p.name for p in (out / BLOCKS_FOLDER).iterdir()) == ["notes.txt"]


def test_a_damaged_block_file_is_computed_again(tmp_path, monkeypatch):
    m = paper_map("intel")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 4)
    damaged = out / BLOCKS_FOLDER / f"block_0_{BLOCK}.npz"
    damaged.write_bytes(damaged.read_bytes()[:100])
    computed = stop_after(monkeypatch, 10**6)
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    assert res.blocks_reused == 3 and (0, BLOCK, BLOCK, 2 * BLOCK) in computed
    assert_same_graph(res, tj.build_graph(m, config=SMALL))


def test_resume_is_checked(tmp_path):
    m = paper_map("intel")
    with pytest.raises(ValueError, match=r"^resume: expected out_dir, .* received out_dir=None"):
        tj.build_graph_tiled(m, config=SMALL, resume=True)
    with pytest.raises(TypeError, match=r"^resume: "):
        tj.build_graph_tiled(m, config=SMALL, out_dir=tmp_path, resume="yes")
    # nothing to resume from: every block computed
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=tmp_path, resume=True)
    assert res.blocks_reused == 0


def test_blocks_another_build_wrote_into_the_folder_are_not_used(tmp_path, monkeypatch):
    """Two builds sharing an out_dir: the files of one land under the other's
    description; each block file names its build, so the other's are computed again."""
    import shutil

    m = paper_map("office")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 3)  # options SMALL
    aside = tmp_path / "aside"
    shutil.copytree(out / BLOCKS_FOLDER, aside)
    done = stop_after(monkeypatch, 1)
    with pytest.raises(KeyboardInterrupt):  # options OTHER: the folder starts afresh
        tj.build_graph_tiled(m, config=OTHER, block_px=BLOCK, out_dir=out)
    monkeypatch.undo()
    for path in aside.glob("block_*.npz"):  # the first build goes on writing its blocks
        if path.name != f"block_{done[0][0]}_{done[0][2]}.npz":
            shutil.copy(path, out / BLOCKS_FOLDER / path.name)
    res = tj.build_graph_tiled(m, config=OTHER, block_px=BLOCK, out_dir=out, resume=True)
    assert res.blocks_reused == 1
    assert_same_graph(res, tj.build_graph(m, config=OTHER))


def test_a_blocks_folder_of_other_files_is_refused_not_cleared(tmp_path):
    m = paper_map("intel")
    folder = tmp_path / "graph" / BLOCKS_FOLDER
    folder.mkdir(parents=True)
    (folder / "block_0_0.npz").write_bytes(b"mine")
    with pytest.raises(ValueError, match=r"^out_dir: .* holds files that no tiled build"):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=tmp_path / "graph")
    assert (folder / "block_0_0.npz").read_bytes() == b"mine"
    (tmp_path / "file").mkdir()
    (tmp_path / "file" / BLOCKS_FOLDER).write_text("")
    with pytest.raises(NotADirectoryError, match=r"^out_dir: expected .* it is a file"):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=tmp_path / "file")


def _npy_header(shape, descr="<i8") -> bytes:
    import io

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return buf.getvalue()


def test_a_block_file_claiming_a_huge_array_is_computed_again(tmp_path, monkeypatch):
    """np.load allocates what a header claims before reading it: a block file whose
    member (or a .npy in its place) claims 8 TB, or a plain .npy there (not an archive),
    is computed again, not met with a MemoryError or a TypeError."""
    import io
    import zipfile

    m = paper_map("intel")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 4)
    folder = out / BLOCKS_FOLDER
    first, second, third = (folder / f"block_0_{c}.npz" for c in (0, BLOCK, 2 * BLOCK))
    archive = io.BytesIO()
    with zipfile.ZipFile(first) as z, zipfile.ZipFile(archive, "w") as w:
        for info in z.infolist():
            data = z.read(info)
            if info.filename == "flat.npy":
                data = _npy_header((10**12,)) + bytes(16)
            w.writestr(info.filename, data)
    first.write_bytes(archive.getvalue())
    second.write_bytes(_npy_header((10**12,)) + bytes(16))
    buf = io.BytesIO()
    np.save(buf, np.arange(5))
    third.write_bytes(buf.getvalue())
    computed = stop_after(monkeypatch, 10**6)
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    assert res.blocks_reused == 1
    assert {(0, BLOCK, c, c + BLOCK) for c in (0, BLOCK, 2 * BLOCK)} <= set(computed)
    assert_same_graph(res, tj.build_graph(m, config=SMALL))


def test_a_build_description_that_is_not_an_object_is_refused(tmp_path, monkeypatch):
    m = paper_map("intel")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 1)
    (out / BLOCKS_FOLDER / "build.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"^resume: expected .*build\.json to hold a build "):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)


def test_a_kept_block_replaced_while_the_build_runs_is_refused(tmp_path, monkeypatch):
    """A kept block replaced while the build runs (by another build sharing the folder)
    is refused, not read again at the end as it then is, which would put that build's
    block into the graph."""
    import shutil

    m = paper_map("office")
    out = tmp_path / "graph"
    stopped_build(monkeypatch, m, out, 3)
    other = tmp_path / "other"
    stopped_build(monkeypatch, paper_map("office").to_image() // 2, other, 3)
    (out / BLOCKS_FOLDER / "block_0_0.npz").unlink()  # computed first, the others read after
    real = tiled_build._block_task
    name = f"block_0_{BLOCK}.npz"

    def task(tiled, box, *args):  # the other build writes its block meanwhile
        shutil.copy(other / BLOCKS_FOLDER / name, out / BLOCKS_FOLDER / name)
        return real(tiled, box, *args)

    monkeypatch.setattr(tiled_build, "_block_task", task)
    with pytest.raises(ValueError, match=rf"^out_dir: expected the kept block .*{name} that"):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    (out / BLOCKS_FOLDER / name).unlink()
    monkeypatch.setattr(tiled_build, "_block_task", real)
    stopped_build(monkeypatch, m, out, 3)
    (out / BLOCKS_FOLDER / "block_0_0.npz").unlink()

    def gone(tiled, box, *args):  # or removes the kept blocks (a build without resume)
        (out / BLOCKS_FOLDER / name).unlink(missing_ok=True)
        return real(tiled, box, *args)

    monkeypatch.setattr(tiled_build, "_block_task", gone)
    with pytest.raises(ValueError, match=rf"^out_dir: expected the kept block .*{name} that"):
        tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)


def test_blocks_whose_build_description_was_removed_are_still_used(tmp_path, monkeypatch):
    m = paper_map("office")
    out = tmp_path / "graph"
    done = stopped_build(monkeypatch, m, out, 5)
    (out / BLOCKS_FOLDER / "build.json").unlink()
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out, resume=True)
    assert res.blocks_reused == len(done) == 5
    assert_same_graph(res, tj.build_graph(m, config=SMALL))
    # without resume they are cleared as the build's own, not refused as another program's
    stopped_build(monkeypatch, m, out, 3)
    (out / BLOCKS_FOLDER / "build.json").unlink()
    res = tj.build_graph_tiled(m, config=SMALL, block_px=BLOCK, out_dir=out)
    assert res.blocks_reused == 0 and not (out / BLOCKS_FOLDER).exists()
