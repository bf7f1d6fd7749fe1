"""ROS 2 MCAP files cut off while recording (the robot powered down): read up to the
cut with a warning, as a cut-off ROS 1 bag is; files that are not MCAP, or hold no whole
message, are refused naming the file."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import topojax as tj
from topojax.scans import read_bag

pytest.importorskip("rosbags")

DATA = Path(__file__).parent / "data"
INTEL_EXCERPT = DATA / "intel_first40.log.gz"


def same_scans(a, b) -> bool:
    return (
        np.array_equal(a.ranges, b.ranges)
        and a.pose == b.pose
        and a.sensor_offset == b.sensor_offset
        and a.timestamp == b.timestamp
    )


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A recording of the 40 intel scans as topojax writes one (rosbags' writer, one
    zstd chunk, then the summary) and the scans read from it whole."""
    from topojax.io.mcap import McapRecorder

    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    with McapRecorder(path) as rec:
        for scan in tj.read_scans(INTEL_EXCERPT):
            rec.add_scan(scan)
    return path, list(read_bag(path))


def write_chunked(path: Path, compression: str, chunk_size: int = 3000) -> Path:
    """The 40 intel scans (``/scan`` and ``/tf``, the sensor offset once on
    ``/tf_static``) in an MCAP file of small chunks with ``compression`` ("", "lz4" or
    "zstd"), written with the ``mcap`` package."""
    mcap_writer = pytest.importorskip("mcap.writer")
    from topojax.io.mcap import (
        TOPICS,
        _typestore,
        scan_message,
        tf_message,
        tf_static_message,
    )

    store = _typestore()
    kinds = {"": "NONE", "lz4": "LZ4", "zstd": "ZSTD"}
    with open(path, "wb") as fh:
        writer = mcap_writer.Writer(
            fh,
            chunk_size=chunk_size,
            compression=getattr(mcap_writer.CompressionType, kinds[compression]),
        )
        writer.start(profile="ros2", library="test")
        channels = {}
        for topic in ("/scan", "/tf", "/tf_static"):
            text = store.generate_msgdef(TOPICS[topic], ros_version=2)[0]
            sid = writer.register_schema(TOPICS[topic], "ros2msg", text.encode())
            channels[topic] = writer.register_channel(topic, "cdr", sid)
        for i, scan in enumerate(tj.read_scans(INTEL_EXCERPT)):
            ns = (i + 1) * 100_000_000
            messages = [("/tf", tf_message(scan, ns)), ("/scan", scan_message(scan, ns))]
            if i == 0:
                messages.insert(0, ("/tf_static", tf_static_message(scan, ns)))
            for topic, msg in messages:
                data = store.serialize_cdr(msg, TOPICS[topic])
                writer.add_message(channels[topic], log_time=ns, data=data, publish_time=ns)
        writer.finish()
    return path


def test_a_recording_cut_after_its_chunk_reads_every_scan(recording, tmp_path):
    """Cut in the message indexes, the summary or the footer: rosbags refused it ("File
    end magic is invalid"); every scan is there, with a warning naming the file and the
    count of messages read."""
    path, whole = recording
    data = path.read_bytes()
    end_of_chunk = 43 + 9 + int.from_bytes(data[44:52], "little")  # header, then the chunk
    cut = tmp_path / "cut.mcap"
    for size in (end_of_chunk, end_of_chunk + 100, len(data) - 200, len(data) - 30):
        cut.write_bytes(data[:size])
        # 40 scans, their 40 /tf and the sensor offset's one /tf_static
        match = r"cut\.mcap: the MCAP file is cut off at the record at byte \d+ .* read 81 messages"
        with pytest.warns(RuntimeWarning, match=match):
            scans = list(read_bag(cut))
        assert len(scans) == len(whole) == 40
        assert all(same_scans(a, b) for a, b in zip(scans, whole, strict=True))


@pytest.mark.parametrize("compression", ["", "lz4", "zstd"])
def test_a_chunked_recording_cut_anywhere_reads_the_scans_before_the_cut(tmp_path, compression):
    path = write_chunked(tmp_path / "whole.mcap", compression)
    whole = list(read_bag(path))
    assert len(whole) == 40
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    counts = []
    for size in np.linspace(len(data) // 8, len(data) - 40, 9).astype(int):
        cut.write_bytes(data[:size])
        with pytest.warns(RuntimeWarning, match=r"cut\.mcap: .* read \d+ messages up to"):
            scans = list(read_bag(cut))
        assert all(same_scans(a, b) for a, b in zip(scans, whole, strict=False))
        counts.append(len(scans))
    assert counts == sorted(counts) and 0 < counts[0] and counts[len(counts) // 2] < 40
    assert counts[-1] == 40


def test_a_cut_inside_a_chunk_keeps_the_messages_before_it(tmp_path):
    """Uncompressed or block by block, the part of a chunk before the cut is read."""
    path = write_chunked(tmp_path / "whole.mcap", "", chunk_size=1 << 20)  # one chunk
    whole = list(read_bag(path))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.warns(RuntimeWarning, match="cut off"):
        scans = list(read_bag(cut))
    assert 5 < len(scans) < 40
    assert all(same_scans(a, b) for a, b in zip(scans, whole, strict=False))


def test_an_mcap_cut_before_its_first_message_is_refused(recording, tmp_path):
    path, _ = recording
    cut = tmp_path / "early.mcap"
    for size in (10, 60, 2000):
        cut.write_bytes(path.read_bytes()[:size])
        with pytest.raises(ValueError, match=r"early\.mcap: the MCAP file holds no whole message"):
            read_bag(cut)


def test_a_record_length_past_the_end_of_the_file_is_a_cut_not_a_huge_read(recording, tmp_path):
    # garbage after the magic: a record head claiming 2**62 bytes reads what is there
    path, _ = recording
    bad = tmp_path / "garbage.mcap"
    bad.write_bytes(
        path.read_bytes()[:8] + bytes([0x05]) + (2**62).to_bytes(8, "little") + b"x" * 50
    )
    with pytest.raises(ValueError, match=r"garbage\.mcap: the MCAP file holds no whole message"):
        read_bag(bad)


@pytest.mark.parametrize("cut", [False, True])
def test_a_recording_damaged_inside_its_chunk_is_refused_naming_it(recording, tmp_path, cut):
    """Bytes of the zstd chunk overwritten: the decompressor's own error (ZstdError,
    which the command line would print as a traceback) is a ValueError naming the file,
    whole (rosbags reads it) or cut as well (read record by record).  The bytes are the
    start of the zstd frame, which zstd checks whatever the scans hold (bytes of a block
    further in may decompress, unnoticed, to other bytes)."""
    path, _ = recording
    data = path.read_bytes()
    end_of_chunk = 43 + 9 + int.from_bytes(data[44:52], "little")
    # the chunk's times, sizes and CRC (28 bytes), "zstd" (4 + 4) and the records' length
    frame = 43 + 9 + 28 + 8 + 8
    assert data[frame : frame + 4] == b"\x28\xb5\x2f\xfd"  # zstd's magic number
    damaged = data[:frame] + bytes(b ^ 0xFF for b in data[frame : frame + 64])
    damaged += data[frame + 64 :]
    bad = tmp_path / "damaged.mcap"
    bad.write_bytes(damaged[: end_of_chunk + 100] if cut else damaged)
    with warnings.catch_warnings():
        # cut: where the damage decompresses (to bytes no message decodes from), the cut
        # is found first and warned of, as it should be, before the refusal
        warnings.filterwarnings(
            "ignore", r".*damaged\.mcap: the MCAP file is cut off", RuntimeWarning
        )
        with pytest.raises(ValueError, match=r"damaged\.mcap.* (does not decompress|is damaged)"):
            list(tj.read_scans(bad))


def test_a_file_that_is_not_mcap_is_refused_naming_it(tmp_path):
    fake = tmp_path / "fake.mcap"
    fake.write_bytes(b"this is not a recording\n" * 10)
    with pytest.raises(ValueError, match=r"fake\.mcap is not an MCAP file"):
        read_bag(fake)


def test_read_scans_reads_a_cut_recording(recording, tmp_path):
    """The suffix-free path through read_scans: the MCAP magic picks the bag reader."""
    path, whole = recording
    cut = tmp_path / "cut_recording"
    cut.write_bytes(path.read_bytes()[:-30])
    with pytest.warns(RuntimeWarning, match="cut off"):
        scans = list(tj.read_scans(cut))
    assert len(scans) == len(whole)


@pytest.mark.parametrize("compression", ["", "lz4", "zstd"])
def test_the_record_reader_gives_the_messages_rosbags_gives(tmp_path, compression, recording):
    """On whole files (which rosbags reads), the reader of cut-off files yields the same
    messages in the same order, decoded alike."""
    from topojax.scans._mcap import _McapSequential
    from topojax.scans.bag import _AnyReaderSource

    for path in (write_chunked(tmp_path / "whole.mcap", compression), recording[0]):
        ours = list(_McapSequential(path).messages(["/scan", "/tf"]))
        theirs = list(_AnyReaderSource(path).messages(["/scan", "/tf"]))
        assert [m[:3] for m in ours] == [m[:3] for m in theirs] and len(ours) == 80
        for (topic, *_, a), (*_, b) in zip(ours, theirs, strict=True):
            if topic == "/scan":
                np.testing.assert_array_equal(a.ranges, b.ranges)
            else:  # classes of two typestores: compare the fields
                for ta, tb in zip(a.transforms, b.transforms, strict=True):
                    ra, rb = ta.transform.rotation, tb.transform.rotation
                    assert ta.child_frame_id == tb.child_frame_id
                    assert (ra.x, ra.y, ra.z, ra.w) == (rb.x, rb.y, rb.z, rb.w)
                    assert ta.transform.translation.x == tb.transform.translation.x


def test_a_bag_folder_of_one_cut_mcap_reads_it(recording, tmp_path):
    """A ROS 2 bag folder whose recording stopped has no metadata.yaml (written at the
    end), only its .mcap file: the folder reads as that file."""
    path, whole = recording
    folder = tmp_path / "rosbag2_run"
    folder.mkdir()
    (folder / "rosbag2_run_0.mcap").write_bytes(path.read_bytes()[:-30])
    with pytest.warns(RuntimeWarning, match=r"rosbag2_run_0\.mcap: the MCAP file is cut off"):
        scans = list(read_bag(folder))
    assert len(scans) == len(whole)


def test_a_folder_that_is_not_a_bag_is_refused_saying_so(tmp_path):
    """A folder without metadata.yaml and without one .mcap file (a bag's parent folder,
    say) is refused saying what a bag folder holds, not with rosbags' 'Expected metadata
    file FOLDER does not exist' about a folder that does exist."""
    (tmp_path / "notes.txt").write_text("not a bag\n")
    with pytest.raises(ValueError, match=r"is a folder but not a ROS 2 bag: expected") as info:
        list(tj.read_scans(tmp_path))
    assert str(tmp_path) in str(info.value) and "metadata.yaml" in str(info.value)


def test_a_folder_of_several_recordings_is_refused_counting_them(recording, tmp_path):
    """A folder of MCAP recordings without metadata.yaml is no bag: the message counts
    its .mcap files rather than saying it found none."""
    for name in ("a.mcap", "b.mcap"):
        (tmp_path / name).write_bytes(recording[0].read_bytes())
    with pytest.raises(ValueError, match=r"not a ROS 2 bag: .*found 2 \.mcap files; pass"):
        list(tj.read_scans(tmp_path))
