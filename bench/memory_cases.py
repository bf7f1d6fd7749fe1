"""Process memory probes and the replay and batch cases of ``bench_memory.py``.

Probes: the resident set size (``/proc/self/statm``), the kernel's high-water mark
(``VmHWM``) of this or another process and its reset (``/proc/self/clear_refs``), and
:class:`PeakSampler`, a thread that keeps only the running peak of the RSS (so a long
measurement does not grow the heap it measures).

Cases (each in a fresh process, started by ``bench_memory.py``):

``replay_<log>`` (:func:`replay_worker`)
    A CARMEN log (:data:`LOGS`, corrected poses) replayed scan by scan into an
    :class:`topojax.IncrementalMapper` with its defaults (graph every 80 scans, no rooms)
    and a final ``update_graph``: the peak RSS growth over the replay, per pixel of the
    mapper's final bounding box.  Then every dense export, one at a time, in the order of
    :func:`mapper_exports`, each with the high-water mark reset before it and its result
    freed after it: peak growth per pixel of what it returns, time, and what stays
    resident (the mapper caches ``distance`` and ``graph``, so ``to_result``, which
    comes after them, reuses both).  Before the measurements the process replays the
    log's first :data:`WARMUP_SCANS` scans into a throwaway mapper and calls every export
    once (the kernels compile there).
``batch_<map>`` (:func:`batch_map_worker`)
    :func:`topojax.build_graphs` of one shared map (:data:`BATCH_MAPS`) with
    ``workers=0`` (load, kernels, CPU stage and the default graph files in this
    process), after a warm-up batch of a small map: peak growth per map pixel and time.
``batch_pool2`` (:func:`batch_pool_worker`)
    ``build_graphs`` of all :data:`BATCH_MAPS` with ``workers=2`` (the default process
    pool: the workers read the maps and run the CPU stages, the parent the kernels; one
    ``map_mode`` for all, so every file is read by its own convention, the IPA images as
    plain trinary images): the parent's peak growth, and each pool process's ``VmHWM``
    read from ``/proc`` while it lives (every 10 ms).
"""

from __future__ import annotations

import ctypes
import dataclasses
import gc
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

#: CARMEN logs (corrected poses) of the replay cases, relative to the data folder.
LOG_DIR = "logs/carmen_corrected"
LOGS = {
    "intel": "intel-corrected.log.gz",
    "fr079": "freiburg-079-corrected.log.gz",
    "aces": "aces-corrected.log.gz",
}
REPLAY_CASES = ("replay_intel", "replay_aces", "replay_fr079")
#: Scans of the warm-up replay (kernels compile, every export runs once).
WARMUP_SCANS = 200
#: Maps of the batch cases (relative to the data folder) and their ``map_mode``.
BATCH_MAPS = {
    "office_g": ("maps/ipa/office_g.png", "ipa"),
    "office_i": ("maps/ipa/office_i.png", "ipa"),
    "pal_office_7th_floor": ("maps/ros/pal_office_7th_floor/map.yaml", None),
    "tuw_freihaus_eg": ("maps/ros/tuw_freihaus_eg/map.yaml", None),
    "turtlebot3_office": ("maps/ros/turtlebot3_office/map_office.yaml", None),
}
BATCH_CASES = tuple(f"batch_{m}" for m in BATCH_MAPS) + ("batch_pool2",)
#: The warm-up map of the batch cases (in the repository).
BATCH_WARMUP = "topojax/data/intel.png"
SAMPLE_S = 0.001
CHILD_SAMPLE_S = 0.01
MB = 2**20


# --------------------------------------------------------------------------- probes


def rss_bytes() -> int:
    """Resident set size of this process (bytes), from ``/proc/self/statm``."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def hwm_bytes(pid: int | str = "self") -> int | None:
    """The kernel's peak RSS of a process (``VmHWM``, bytes), or None."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def reset_hwm() -> bool:
    """Reset ``VmHWM`` to the current RSS (Linux >= 4.0); False where it cannot be."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def release_freed() -> None:
    """Collect garbage and hand the C heap's free pages back (glibc ``malloc_trim``), so
    the next baseline does not count memory the next measurement would reuse."""
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


class PeakSampler(threading.Thread):
    """Keeps the peak of :func:`rss_bytes`, sampled every :data:`SAMPLE_S` seconds, since
    the last :meth:`restart`; ends the process (exit status 3, one JSON line) above
    ``limit`` bytes."""

    def __init__(self, limit: float) -> None:
        super().__init__(daemon=True)
        self.limit = limit
        self.peak = rss_bytes()
        self.running = True

    def restart(self) -> None:
        self.peak = rss_bytes()

    def run(self) -> None:
        while self.running:
            v = rss_bytes()
            if v > self.peak:
                self.peak = v
            if v > self.limit:
                print(json.dumps({"error": f"memory limit {self.limit / 2**30:.1f} GiB passed"}))
                sys.stdout.flush()
                os._exit(3)
            time.sleep(SAMPLE_S)


class Measure:
    """Peak RSS growth and time of calls, one at a time, with a :class:`PeakSampler`."""

    def __init__(self, limit_gb: float) -> None:
        self.sampler = PeakSampler(limit_gb * 2**30)
        self.sampler.start()
        self.hwm_ok = reset_hwm()

    def __call__(self, fn) -> tuple[Any, dict[str, float]]:
        """``fn()`` and ``{"base_mb", "peak_mb", "resident_mb", "s"}``: RSS before, peak
        growth over it, growth still resident after (with the result alive), seconds."""
        release_freed()
        base = rss_bytes()
        self.hwm_ok = reset_hwm() and self.hwm_ok
        self.sampler.restart()
        t0 = time.perf_counter()
        out = fn()
        t1 = time.perf_counter()
        peak = max(self.sampler.peak, rss_bytes(), (hwm_bytes() or 0) if self.hwm_ok else 0)
        return out, {
            "base_mb": base / MB,
            "peak_mb": (peak - base) / MB,
            "resident_mb": (rss_bytes() - base) / MB,
            "s": t1 - t0,
        }

    @staticmethod
    def retained(m: dict[str, float]) -> float:
        """MB still resident over ``m``'s baseline once garbage is freed (call after
        dropping the result)."""
        release_freed()
        return rss_bytes() / MB - m["base_mb"]

    def stop(self) -> None:
        self.sampler.running = False
        self.sampler.join()


def _per_px(m: dict[str, float], px: int) -> dict[str, float]:
    return {**m, "peak_b_px": m["peak_mb"] * MB / px, "resident_b_px": m["resident_mb"] * MB / px}


# --------------------------------------------------------------------------- replay


def _scans(path: Path, limit: int | None = None):
    import topojax as tj

    for i, scan in enumerate(tj.read_scans(path)):
        if limit is not None and i >= limit:
            return
        yield scan


def _replay(mapper, scans) -> tuple[int, int]:
    """Add every scan; a scan refused for growing the map too far (a localisation glitch)
    is skipped, as ``topojax.replay`` does.  Returns (scans added, scans skipped)."""
    added = skipped = 0
    for scan in scans:
        try:
            mapper.add_scan(scan)
            added += 1
        except ValueError:
            skipped += 1
    mapper.update_graph()
    return added, skipped


def mapper_exports(mapper, folder: Path) -> dict[str, Any]:
    """The dense exports of ``mapper``, in the order they are measured: name -> call."""
    r0, c0, r1, c1 = mapper.pixel_bbox
    res = mapper.resolution_m
    # the whole bounding box, half a pixel inside its edges
    window = ((c0 + 0.5) * res, (-r1 + 0.5) * res, (c1 - 0.5) * res, (-r0 - 0.5) * res)
    return {
        "occupancy": lambda: mapper.occupancy,
        "occupancy_window": lambda: mapper.occupancy_window(window),
        "obstacles": lambda: mapper.obstacles,
        "ridges": lambda: mapper.ridges,
        "lap_abs": lambda: mapper.lap_abs,
        "skeleton": lambda: mapper.skeleton,
        "sq_distance_px": lambda: mapper.sq_distance_px,
        "distance": lambda: mapper.distance,
        "graph": lambda: mapper.graph,
        "graph_global": lambda: mapper.graph_global,
        "to_result": lambda: mapper.to_result(),
        "route_graph": lambda: mapper.route_graph(),
        "save": lambda: mapper.save(folder / "state.npz"),
    }


def _described(out: Any, bbox_px: int) -> dict[str, Any]:
    """Pixels (for the per-pixel figures), array bytes and graph size of an export."""
    import networkx as nx
    import numpy as np

    if isinstance(out, np.ndarray):
        return {"px": int(out.shape[0] * out.shape[1]), "array_mb": out.nbytes / MB}
    if isinstance(out, nx.Graph):
        return {"px": bbox_px, "vertices": out.number_of_nodes(), "edges": out.number_of_edges()}
    if isinstance(out, Path):
        return {"px": bbox_px, "file_mb": out.stat().st_size / MB}
    shape = out.map.shape if hasattr(out, "map") else out.shape
    arrays = _array_bytes(out) + (_array_bytes(out.map) if hasattr(out, "map") else 0)
    return {"px": int(shape[0] * shape[1]), "array_mb": arrays / MB}


def _array_bytes(obj: Any) -> int:
    import numpy as np

    return sum(
        v.nbytes
        for f in dataclasses.fields(obj)
        if isinstance(v := obj.__dict__.get(f.name), np.ndarray)
    )


def replay_worker(args) -> None:
    """One ``replay_<log>`` case in this fresh process; prints one JSON line."""
    import topojax as tj

    log = args.worker.removeprefix("replay_")
    if log not in LOGS:
        raise ValueError(f"case {args.worker!r}: expected replay_<log>, log one of {tuple(LOGS)}")
    path = Path(args.data) / LOG_DIR / LOGS[log]
    folder = Path(tempfile.mkdtemp(prefix="topojax_replay_"))
    try:
        warm = tj.IncrementalMapper()
        _replay(warm, _scans(path, WARMUP_SCANS))
        for fn in mapper_exports(warm, folder).values():
            fn()
        del warm, fn
        measure = Measure(args.limit_gb)
        mapper = tj.IncrementalMapper()
        (added, skipped), m = measure(lambda: _replay(mapper, _scans(path)))
        r0, c0, r1, c1 = mapper.pixel_bbox
        px = (r1 - r0) * (c1 - c0)
        tile_px = mapper.tile_px
        payload: dict[str, Any] = {
            "case": args.worker,
            "class": "replay",
            "log": str(path.relative_to(Path(args.data))),
            "scans": added,
            "skipped_scans": skipped,
            "bbox_shape": [r1 - r0, c1 - c0],
            "bbox_px": px,
            "tiles": mapper.n_tiles,
            "tile_px": tile_px,
            "allocated_px": mapper.n_tiles * tile_px * tile_px,
            "max_export_bytes": mapper.max_export_bytes,
            "max_extent_m": mapper.max_extent_m,
            "graph_every": mapper.graph_every,
            "replay": {**_per_px(m, px), "ms_per_scan": 1e3 * m["s"] / max(added, 1)},
            "exports": {},
        }
        for name, fn in mapper_exports(mapper, folder).items():
            out, m = measure(fn)
            d = _described(out, px)
            del out
            m["retained_mb"] = measure.retained(m)
            m = _per_px(m, d["px"])
            m["retained_b_px"] = m["retained_mb"] * MB / d["px"]
            payload["exports"][name] = {**d, **m}
        measure.stop()
        payload["hwm_reset"] = measure.hwm_ok
        payload["topojax_file"] = tj.__file__
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(json.dumps(payload))


# --------------------------------------------------------------------------- batch


def _warm_batch(root: Path, folder: Path) -> None:
    """A batch of the small warm-up map in this process (kernels compile, numba caches
    load, the file writers import), and ``build_graph`` of it (for the comparison)."""
    import topojax as tj

    tj.build_graphs([root / BATCH_WARMUP], workers=0, out_dir=folder / "warm", progress=False)
    tj.build_graph(tj.load_map(root / BATCH_WARMUP)).graph.number_of_nodes()
    release_freed()


def _record_facts(rec) -> dict[str, Any]:
    px = (rec.height or 0) * (rec.width or 0)
    return {
        "map": rec.map,
        "status": rec.status,
        "shape": [rec.height, rec.width],
        "pixels": px,
        "vertices": rec.vertices,
        "edges": rec.edges,
        "t_load_s": rec.t_load_s,
        "t_distance_s": rec.t_distance_s,
        "t_thinning_s": rec.t_thinning_s,
        "t_graph_s": rec.t_graph_s,
        "t_write_s": rec.t_write_s,
        "files": len(rec.outputs),
    }


def batch_map_worker(args, root: Path) -> None:
    """One ``batch_<map>`` case in this fresh process; prints one JSON line."""
    import topojax as tj

    name = args.worker.removeprefix("batch_")
    if name not in BATCH_MAPS:
        raise ValueError(
            f"case {args.worker!r}: expected batch_<map>, map one of {tuple(BATCH_MAPS)}"
        )
    rel, mode = BATCH_MAPS[name]
    folder = Path(tempfile.mkdtemp(prefix="topojax_batch_"))
    try:
        _warm_batch(root, folder)
        from topojax.pipeline import trace_counts

        traces = trace_counts()
        measure = Measure(args.limit_gb)
        out = folder / "run"
        records, m = measure(
            lambda: tj.build_graphs(
                [Path(args.data) / rel], workers=0, out_dir=out, progress=False, map_mode=mode
            )
        )
        facts = _record_facts(records[0])
        del records
        m["retained_mb"] = measure.retained(m)
        m["retained_b_px"] = m["retained_mb"] * MB / facts["pixels"]
        compare = _batch_stages_alone(Path(args.data) / rel, mode, measure)
        measure.stop()
        payload = {
            "case": args.worker,
            "class": "batch",
            "path": rel,
            "map_mode": mode,
            "workers": 0,
            **facts,
            **_per_px(m, facts["pixels"]),
            "files_mb": sum(f.stat().st_size for f in out.iterdir()) / MB,
            "kernel_traced": trace_counts() != traces,
            "alone": compare,
            "hwm_reset": measure.hwm_ok,
            "topojax_file": tj.__file__,
        }
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(json.dumps(payload))


def _batch_stages_alone(path: Path, mode: str | None, measure: Measure) -> dict[str, Any]:
    """After the batch, in the same process: peak growth per pixel of the batch's kernel
    stage alone (``ridge_fields_many`` of the map, as the batch calls it) and of
    ``build_graph`` of the same map (its ``.graph`` read)."""
    import topojax as tj
    from topojax.fields import ridge_fields_many

    occ = tj.load_map(path, mode=mode) if mode else tj.load_map(path)
    px = int(occ.occupied.size)
    cfg = tj.PipelineConfig()
    kw = {"distance": cfg.distance, "ridge": cfg.ridge, "tile_px": cfg.tile_px}
    kw["tiles_per_call"] = max(cfg.tiles_per_call, 16)  # the batch's default
    fields, m = measure(lambda: ridge_fields_many([occ.occupied], **kw))
    out_b = _array_bytes(fields[0][0]) + fields[0][1].nbytes
    kernels = {**_per_px(m, px), "result_b_px": out_b / px}
    del fields
    graph, m = measure(lambda: tj.build_graph(occ).graph)
    del graph
    return {"kernel_stage": kernels, "build_graph": _per_px(m, px)}


class ChildPeaks(threading.Thread):
    """``VmHWM`` of every descendant process seen, read every :data:`CHILD_SAMPLE_S`
    seconds while it lives: pid -> (role, peak bytes)."""

    def __init__(self) -> None:
        super().__init__(daemon=True)
        self.peaks: dict[int, list[Any]] = {}
        self.running = True

    def run(self) -> None:
        import psutil

        me = psutil.Process()
        while self.running:
            for child in me.children(recursive=True):
                hwm = hwm_bytes(child.pid)
                if hwm is None:
                    continue
                entry = self.peaks.get(child.pid)
                if entry is None:
                    try:
                        cmd = " ".join(child.cmdline())
                        parent = child.ppid()
                    except psutil.Error:
                        continue
                    # the workers are forks of the fork server (its command line too)
                    role = "worker" if parent != me.pid else "other"
                    role = "forkserver" if role == "other" and "forkserver" in cmd else role
                    role = "resource_tracker" if "resource_tracker" in cmd else role
                    self.peaks[child.pid] = [role, hwm]
                else:
                    entry[1] = max(entry[1], hwm)
            time.sleep(CHILD_SAMPLE_S)


def batch_pool_worker(args, root: Path) -> None:
    """The ``batch_pool2`` case in this fresh process; prints one JSON line."""
    import topojax as tj

    folder = Path(tempfile.mkdtemp(prefix="topojax_batch_"))
    paths = [Path(args.data) / rel for rel, _ in BATCH_MAPS.values()]
    try:
        _warm_batch(root, folder)
        children = ChildPeaks()
        children.start()
        measure = Measure(args.limit_gb)
        records, m = measure(
            lambda: tj.build_graphs(paths, workers=2, out_dir=folder / "run", progress=False)
        )
        time.sleep(5 * CHILD_SAMPLE_S)
        children.running = False
        children.join()
        facts = [_record_facts(r) for r in records]
        px = sum(f["pixels"] for f in facts)
        del records
        m["retained_mb"] = measure.retained(m)
        m["retained_b_px"] = m["retained_mb"] * MB / px
        measure.stop()
        procs = [
            {"pid": pid, "role": r, "hwm_mb": b / MB} for pid, (r, b) in children.peaks.items()
        ]
        server = [p["hwm_mb"] for p in procs if p["role"] == "forkserver"]
        workers = [p["hwm_mb"] for p in procs if p["role"] == "worker"]
        payload = {
            "case": args.worker,
            "class": "batch",
            "workers": 2,
            "maps": facts,
            "pixels": px,
            "largest_map_px": max(f["pixels"] for f in facts),
            "parent": _per_px(m, px),
            "processes": procs,
            "forkserver_hwm_mb": max(server) if server else None,
            "worker_hwm_mb": max(workers) if workers else None,
            "hwm_reset": measure.hwm_ok,
            "topojax_file": tj.__file__,
        }
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(json.dumps(payload))


# --------------------------------------------------------------------------- reports


def replay_report(results: dict[str, Any]) -> str:
    """Markdown tables of the replay cases: the replay, then every export."""
    from common import markdown_table

    cases = results.get("replay", {}).get("cases", {})
    ok = {c: e for c, e in cases.items() if "error" not in e}
    rows = [
        [
            c,
            e["scans"],
            "×".join(str(v) for v in e["bbox_shape"]),
            e["bbox_px"] / 1e6,
            e["allocated_px"] / 1e6,
            e["replay"]["peak_mb"],
            e["replay"]["peak_b_px"],
            e["replay"]["resident_b_px"],
            e["replay"]["s"],
            e["replay"]["ms_per_scan"],
        ]
        for c, e in ok.items()
    ]
    header = ["log", "scans", "bbox px", "bbox Mpx", "tiles Mpx", "peak MB", "peak B/px"]
    text = [markdown_table(header + ["state B/px", "s", "ms/scan"], rows)]
    names = [n for e in ok.values() for n in e["exports"]]
    names = list(dict.fromkeys(names))
    rows = []
    for n in names:
        row: list[Any] = [n]
        for e in ok.values():
            x = e["exports"].get(n, {})
            row += [x.get("peak_b_px"), x.get("retained_b_px"), x.get("s")]
        rows.append(row)
    header = ["export"] + [f"{c} {k}" for c in ok for k in ("peak B/px", "kept after B/px", "s")]
    text += ["", markdown_table(header, rows)]
    text += [f"- {c}: {e['error']}" for c, e in cases.items() if "error" in e]
    return "\n".join(text) + "\n"


def batch_report(results: dict[str, Any]) -> str:
    """Markdown table of the batch cases (one map in process; the pool over all)."""
    from common import markdown_table

    cases = results.get("batch", {}).get("cases", {})
    rows = []
    for c, e in cases.items():
        if "error" in e:
            rows.append([c, e["error"]] + [""] * 9)
        elif e["workers"] == 0:
            alone = e.get("alone", {})
            rows.append(
                [c, 0, e["pixels"] / 1e6, e["vertices"], e["edges"], e["peak_mb"]]
                + [e["peak_b_px"], e.get("retained_b_px"), e["s"]]
                + [alone.get(k, {}).get("peak_b_px") for k in ("kernel_stage", "build_graph")]
            )
        else:
            p = e["parent"]
            rows.append(
                [f"{c} (parent)", e["workers"], e["pixels"] / 1e6, None, None, p["peak_mb"]]
                + [p["peak_b_px"], p.get("retained_b_px"), p["s"], None, None]
            )
    header = ["case", "workers", "Mpx", "V", "E", "peak MB", "peak B/px", "kept after B/px"]
    header += ["s", "kernel stage alone B/px", "build_graph B/px"]
    text = [markdown_table(header, rows)]
    for c, e in cases.items():
        if "processes" in e:
            text.append(
                f"\n{c}: fork server VmHWM {e['forkserver_hwm_mb']} MB, "
                f"largest worker VmHWM {e['worker_hwm_mb']} MB"
            )
    return "\n".join(text) + "\n"
