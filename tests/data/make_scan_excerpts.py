"""Regenerate the small laser-scan excerpts in this folder from ../shared/data (run once).

Usage: ``python tests/data/make_scan_excerpts.py`` from the repository root. The excerpts are
plain prefixes / subsets of the original files; no value is changed (see README.md).
"""

from __future__ import annotations

import gzip
from pathlib import Path

HERE = Path(__file__).resolve().parent
LOGS = HERE.parents[2] / "shared" / "data" / "logs"


def carmen_prefix(src: Path, dst: Path, n_scans: int) -> None:
    """Copy the lines of ``src`` up to and including its ``n_scans``-th FLASER line."""
    out: list[str] = []
    seen = 0
    with gzip.open(src, "rt", encoding="latin-1", newline="") as fh:
        for line in fh:
            out.append(line)
            if line.startswith("FLASER "):
                seen += 1
                if seen == n_scans:
                    break
    with open(dst, "wb") as raw, gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0) as gz:
        gz.write("".join(out).encode("latin-1"))


def octave_prefix(src: Path, dst: Path, n_cells: int) -> None:
    """Keep the first ``n_cells`` elements of every 1 x N cell field of the ``laser`` struct."""
    lines = src.read_text(encoding="latin-1").splitlines(keepends=True)
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        is_field = line.startswith("# name: ") and not line.startswith("# name: <cell-element>")
        if is_field and i + 3 < len(lines) and lines[i + 1].strip() == "# type: cell":
            assert lines[i + 2].strip() == "# rows: 1", lines[i + 2]
            assert lines[i + 3].startswith("# columns: "), lines[i + 3]
            out += [line, lines[i + 1], lines[i + 2], f"# columns: {n_cells}\n"]
            i += 4
            kept = 0
            while i < len(lines):
                cur = lines[i]
                starts_elem = cur.startswith("# name: <cell-element>")
                if cur.startswith("# name: ") and not starts_elem:
                    break  # next field
                if starts_elem:
                    kept += 1
                if kept <= n_cells:
                    out.append(cur)
                i += 1
            continue
        out.append(line)
        i += 1
    dst.write_text("".join(out), encoding="latin-1")


def bag_prefix(src: Path, dst: Path, n_msgs: int) -> None:
    """Copy the first ``n_msgs`` messages: raw bytes, original definition, md5sum, callerid."""
    from rosbags.rosbag1 import Writer

    from topojax.scans._ros1 import _Ros1Sequential

    reader = _Ros1Sequential(src)
    if dst.exists():
        dst.unlink()
    written = 0
    with Writer(dst) as writer:
        out = {}
        for cid, t_ns, raw in reader._records(want_messages=True):
            c = reader.connections[cid]
            if cid not in out:
                out[cid] = writer.add_connection(
                    c.topic, c.msgtype, msgdef=c.msgdef, md5sum=c.md5sum, callerid=c.callerid
                )
            writer.write(out[cid], t_ns, raw)
            written += 1
            if written == n_msgs:
                break


if __name__ == "__main__":
    carmen_prefix(
        LOGS / "carmen_corrected" / "intel-corrected.log.gz", HERE / "intel_first40.log.gz", 40
    )
    octave_prefix(
        LOGS / "robot_mapping_course" / "csail_laser_octave.txt",
        HERE / "csail_laser_octave_first20.txt",
        20,
    )
    bag_prefix(
        LOGS / "rosbag" / "ccny_laser_scan_matcher_demo.bag", HERE / "ccny_demo_first25.bag", 25
    )
    for p in sorted(HERE.iterdir()):
        print(p.name, p.stat().st_size)
