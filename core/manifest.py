"""The assets manifest (``assets_manifest.yaml``): objects, cameras, data sources, sample data sums.

- :func:`load_manifest` reads it (cached); :func:`object_names`, :func:`object_entry`,
  :func:`camera_for_video` answer the usual questions.
- :func:`verify_assets` checks a local copy of the sample data against the recorded sha256 sums
  (``ycbvss assets verify --root DIR``).
- :func:`find_symmetries` is how the BOP ``symmetries_*`` entries of the manifest were derived from
  the meshes (in the BOP frame: recentred on the bounding-box centre, mm); ``python -m
  ycbvss.manifest --shared DIR`` regenerates the computed parts (sums, symmetries) and prints YAML.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh
import yaml
from scipy.spatial import cKDTree

from .errors import YcbvssError
from .geometry.so3 import exp_so3
from .io.mesh import diameter_mm, load_mesh_mm

MANIFEST_PATH = Path(__file__).resolve().parent / "assets_manifest.yaml"


@lru_cache(maxsize=4)
def _load(path: str) -> dict:
    p = Path(path)
    if not p.is_file():
        raise YcbvssError("missing assets manifest", p)
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as e:
        raise YcbvssError(f"malformed YAML: {str(e).splitlines()[0]}", p) from None
    if not isinstance(data, dict) or "objects" not in data:
        raise YcbvssError("not an assets manifest (no 'objects')", p)
    return data


def load_manifest(path: str | Path | None = None) -> dict:
    """The parsed manifest (dict). Default: the one shipped with the package."""
    return _load(str(Path(path) if path else MANIFEST_PATH))


def object_entries(manifest: dict | None = None) -> dict[int, dict]:
    """obj_id -> manifest entry (name, textureless, protocol_symmetric, bop symmetries, note)."""
    m = manifest or load_manifest()
    return {int(o["obj_id"]): o for o in m["objects"]}


def object_entry(obj_id: int, manifest: dict | None = None) -> dict | None:
    return object_entries(manifest).get(int(obj_id))


def object_names(manifest: dict | None = None) -> dict[int, str]:
    """obj_id (BOP, = YCB-Video class index) -> YCB name, e.g. 1 -> '002_master_chef_can'."""
    return {k: v["name"] for k, v in object_entries(manifest).items()}


def obj_id_by_name(manifest: dict | None = None) -> dict[str, int]:
    return {v: k for k, v in object_names(manifest).items()}


def protocol_symmetric_ids(manifest: dict | None = None) -> tuple[int, ...]:
    """Objects evaluated with ADD-S in the paper's ADD(-S) protocol (default: (13,) = 024_bowl)."""
    return tuple(sorted(k for k, v in object_entries(manifest).items() if v.get("protocol_symmetric")))


def bop_symmetries(obj_id: int, manifest: dict | None = None) -> tuple[list, list]:
    """(symmetries_discrete as 4x4 arrays, symmetries_continuous dicts) in the BOP frame, mm."""
    e = object_entry(obj_id, manifest) or {}
    s = e.get("bop_symmetries") or {}
    disc = [np.asarray(S, np.float64).reshape(4, 4) for S in s.get("symmetries_discrete", [])]
    cont = [dict(axis=list(c["axis"]), offset=list(c.get("offset", [0, 0, 0])))
            for c in s.get("symmetries_continuous", [])]
    return disc, cont


def cameras(manifest: dict | None = None) -> dict[str, dict]:
    m = manifest or load_manifest()
    return m["cameras"]


def camera_for_video(video: int, manifest: dict | None = None) -> tuple[str, np.ndarray]:
    """(camera name, K 3x3) of a YCB-Video video number: 'uw' for 0-59 (and synthetic), 'cmu' 60-91."""
    for name, cam in cameras(manifest).items():
        lo, hi = cam["videos"]
        if lo <= int(video) <= hi:
            return name, np.asarray(cam["K"], np.float64)
    raise YcbvssError(f"no YCB-Video camera for video {video:04d} in the assets manifest")


# ------------------------------------------------------------------ sample-data sums
def sha256_file(path: str | Path, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


def sample_data_sums(root: str | Path) -> dict[str, str]:
    """sha256 of every file under ``root`` (relative POSIX paths, sorted)."""
    root = Path(root)
    return {p.relative_to(root).as_posix(): sha256_file(p)
            for p in sorted(root.rglob("*")) if p.is_file()}


def verify_assets(root: str | Path, manifest: dict | None = None) -> list[tuple[str, str]]:
    """Check the files recorded under ``sample_data.files`` against a local copy at ``root``.

    Returns ``[(relative path, 'OK' | 'missing' | 'mismatch')]`` in manifest order.
    """
    m = manifest or load_manifest()
    root = Path(root)
    if not root.is_dir():
        raise YcbvssError("assets root is not a folder", root)
    files = (m.get("sample_data") or {}).get("files") or {}
    out = []
    for rel, digest in files.items():
        p = root / rel
        if not p.is_file():
            out.append((rel, "missing"))
        else:
            out.append((rel, "OK" if sha256_file(p) == digest else "mismatch"))
    return out


# ------------------------------------------------------------------ symmetry derivation
def _rot(axis: str, deg: float) -> np.ndarray:
    w = np.zeros(3)
    w["xyz".index(axis)] = np.deg2rad(deg)
    return exp_so3(w)


def symmetry_deviation_mm(mesh_mm, R: np.ndarray, n_samples: int = 150000, seed: int = 0,
                          _cache: dict | None = None) -> float:
    """Max distance (mm) from the rotated vertices R v to the (densely sampled) unrotated surface."""
    key = id(mesh_mm)
    if _cache is not None and key in _cache:
        tree = _cache[key]
    else:
        pts, _ = trimesh.sample.sample_surface(mesh_mm, n_samples, seed=seed)
        tree = cKDTree(pts)
        if _cache is not None:
            _cache[key] = tree
    v = np.asarray(mesh_mm.vertices, np.float64)
    d, _ = tree.query(v @ np.asarray(R).T)
    return float(d.max())


def find_symmetries(mesh_mm, rel_tol: float = 0.05) -> dict:
    """Axis-aligned geometric symmetries of a mesh in its own (bbox-centred, mm) frame.

    Candidates: continuous rotation about x, y, z (checked at 30/60/120/180 deg); 180 deg
    rotations about x, y, z; 90 deg about an axis whose 180-deg flip is accepted. A candidate
    is accepted when the max distance of the transformed vertices to the original surface is
    <= ``rel_tol`` * diameter. Accepted 180-deg flips are closed under composition (two imply
    the third); with a continuous axis one perpendicular flip is kept. Texture is ignored (as
    BOP's symmetries). Not handled: oblique axes and full dihedral closure of a 90-deg axis
    with perpendicular flips (none occurs among the YCB-V objects at this tolerance). Returns ``{"symmetries_discrete": [16-lists], "symmetries_continuous":
    [{"axis", "offset"}], "max_dev_mm": {candidate: mm}}``.
    """
    tol = rel_tol * diameter_mm(mesh_mm.vertices)
    cache: dict = {}
    dev = {}
    cont_axes = []
    for ax in "xyz":
        dev[f"{ax}_cont"] = max(symmetry_deviation_mm(mesh_mm, _rot(ax, a), _cache=cache)
                                for a in (30, 60, 120, 180))
        if dev[f"{ax}_cont"] <= tol:
            cont_axes.append(ax)
    flips = []
    for ax in "xyz":
        dev[f"{ax}180"] = symmetry_deviation_mm(mesh_mm, _rot(ax, 180), _cache=cache)
        if dev[f"{ax}180"] <= tol and ax not in cont_axes:
            flips.append(ax)
    quarter = []
    for ax in "xyz":
        if ax in cont_axes:
            continue
        dev[f"{ax}90"] = symmetry_deviation_mm(mesh_mm, _rot(ax, 90), _cache=cache)
        if dev[f"{ax}90"] <= tol and ax in flips:
            quarter.append(ax)
    if cont_axes:   # with a continuous axis, one perpendicular flip generates the others
        flips = flips[:1]
    elif len(flips) == 2:
        flips = ["x", "y", "z"]
    disc = [(ax, 180) for ax in flips]
    for ax in quarter:
        disc += [(ax, 90), (ax, 270)]
    mats = []
    for ax, deg in sorted(set(disc)):
        T = np.eye(4)
        T[:3, :3] = np.round(_rot(ax, deg), 12) + 0.0
        mats.append(T.reshape(-1).tolist())
    out = {"max_dev_mm": {k: round(v, 2) for k, v in dev.items()}, "tolerance_mm": round(tol, 2)}
    if mats:
        out["symmetries_discrete"] = mats
    if cont_axes:
        out["symmetries_continuous"] = [{"axis": [1.0 * (a == c) for c in "xyz"], "offset": [0.0, 0.0, 0.0]}
                                        for a in cont_axes]
    return out


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Regenerate the computed parts of assets_manifest.yaml")
    ap.add_argument("--shared", required=True, help="the shared data root (../shared/data)")
    ap.add_argument("--what", choices=["sums", "symmetries"], default="sums")
    a = ap.parse_args(argv)
    root = Path(a.shared)
    if a.what == "sums":
        print(yaml.safe_dump({"files": sample_data_sums(root)}, sort_keys=False))
        return 0
    for oid, name in object_names().items():
        m = load_mesh_mm(root / "ycbv" / "models" / name / "textured.obj", 1000.0)
        m = trimesh.Trimesh(m.vertices - (m.bounds[0] + m.bounds[1]) / 2, m.faces, process=False)
        print(json.dumps({"obj_id": oid, "name": name, "bop_symmetries": find_symmetries(m)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
