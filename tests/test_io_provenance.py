"""ycbvss.io.provenance: the image digest tells files apart by content, name and order; the host
record names the CPU, its ISA flags and the versions that shape rendered and refined numbers."""
from __future__ import annotations

import json

from ycbvss.io.provenance import ISA_FLAGS, _cpu_info, files_sha256, host_record, rgb_sha256


def _files(tmp_path, contents: dict) -> list:
    out = []
    for name, data in contents.items():
        p = tmp_path / name
        p.write_bytes(data)
        out.append(p)
    return out


def test_files_digest_changes_with_any_byte_name_or_order(tmp_path):
    a, b = _files(tmp_path, {"000000.png": b"\x89PNG first", "000001.png": b"\x89PNG second"})
    d = files_sha256([a, b])
    assert len(d) == 16 and int(d, 16) >= 0
    assert files_sha256([a, b]) == d                         # stable
    assert files_sha256([b, a]) != d                         # order matters
    b.write_bytes(b"\x89PNG secone")                          # one byte
    assert files_sha256([a, b]) != d
    b.write_bytes(b"\x89PNG second")
    assert files_sha256([a, b]) == d
    c = tmp_path / "000002.png"
    c.write_bytes(b"\x89PNG second")                          # same bytes, another name
    assert files_sha256([a, c]) != d


def test_rgb_digest_of_a_scene_folder(tmp_path):
    assert rgb_sha256(tmp_path) is None                      # no rgb/ folder: nothing to digest
    (tmp_path / "rgb").mkdir()
    files = _files(tmp_path / "rgb", {"000001.png": b"b", "000000.png": b"a"})
    (tmp_path / "rgb" / "notes.txt").write_text("not an image")
    assert rgb_sha256(tmp_path) == files_sha256(sorted(files))


def test_cpu_info_reads_model_and_isa_flags(tmp_path):
    f = tmp_path / "cpuinfo"
    f.write_text("processor\t: 0\nmodel name\t: Test CPU @ 2.0GHz\nflags\t\t: fpu sse4_2 avx avx2 fma\n\n"
                 "processor\t: 1\nmodel name\t: Test CPU @ 2.0GHz\nflags\t\t: fpu\n")
    model, flags = _cpu_info(f)
    assert model == "Test CPU @ 2.0GHz"
    assert flags == ["sse4_2", "avx", "avx2", "fma"]          # the first CPU's, in ISA_FLAGS order
    assert _cpu_info(tmp_path / "missing")[1] == []


def test_host_record_is_json_and_names_the_cpu():
    h = host_record()
    assert set(h) >= {"cpu", "isa", "system", "machine", "python", "bpy", "numpy", "opencv"}
    assert isinstance(h["cpu"], str) and h["cpu"]
    assert set(h["isa"]) <= set(ISA_FLAGS)
    assert h["numpy"] is not None                            # installed with ycbvss
    assert json.loads(json.dumps(h)) == h
