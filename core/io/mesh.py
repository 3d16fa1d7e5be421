"""Meshes at the edges: load (PLY/OBJ/XYZ) in millimetres, write BOP-style PLY, models_info.

- :func:`load_mesh_mm`: a ``trimesh.Trimesh`` in mm, loaded with ``process=False`` so the vertex
  list (UV-seam duplicates included) stays as stored and UVs stay per-vertex. A texture that the
  file names but that is missing gives one warning and a grey model.
- :func:`load_vertices_mm`: the metric model points = all vertices as stored in the file, no
  merging (as bop_toolkit uses them).
- :func:`write_ply_mm`: binary little-endian PLY with x/y/z, nx/ny/nz, texture_u/texture_v and
  ``comment TextureFile NAME`` (the layout of the BOP ycbv model files).
- :func:`compute_models_info`: one BOP ``models_info.json`` entry.
"""
from __future__ import annotations

import logging
import re
import warnings
from pathlib import Path

import cv2
import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial.distance import pdist

from ..errors import YcbvssError
from .atomic import atomic_path

_MESH_EXT = {".ply", ".obj", ".off", ".stl", ".glb", ".gltf"}


def _check_file(path, what: str) -> Path:
    if path is None:
        raise YcbvssError(f"{what} path not set")
    path = Path(path)
    if not path.is_file():
        raise YcbvssError(f"missing {what}", path)
    return path


def _texture_reference(path: Path) -> Path | None:
    """The texture file a PLY (``comment TextureFile``) or OBJ (``mtllib`` -> ``map_Kd``) names."""
    try:
        if path.suffix.lower() == ".ply":
            with open(path, "rb") as f:
                for _ in range(64):
                    line = f.readline().decode("latin-1").strip()
                    if line.startswith("comment TextureFile"):
                        return path.parent / line.split(None, 2)[2].strip()
                    if line == "end_header" or not line and f.tell() > 8192:
                        break
        elif path.suffix.lower() == ".obj":
            with open(path, "r", encoding="utf-8", errors="replace") as f:
                for line in f:
                    if line.startswith("mtllib"):
                        mtl = path.parent / line.split(None, 1)[1].strip()
                        if not mtl.is_file():
                            return mtl
                        for ml in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
                            if ml.strip().startswith("map_Kd"):
                                return path.parent / ml.split()[-1].strip()
                        return None
                    if line.startswith("v "):   # mtllib comes before geometry
                        return None
    except (OSError, IndexError):
        return None
    return None


def load_mesh_mm(path, unit_scale: float = 1.0):
    """Load a mesh file as a ``trimesh.Trimesh`` scaled to millimetres (vertices * unit_scale).

    Vertices and faces are kept exactly as stored (``process=False``), so per-vertex UVs of
    textured models survive. A texture file named by the model but missing on disk raises a
    warning (one line) and the model gets a uniform grey colour instead.
    """
    path = _check_file(path, "model file")
    tex = _texture_reference(path)
    tex_missing = tex is not None and not tex.is_file()
    tm_log = logging.getLogger("trimesh")
    old_level = tm_log.level
    tm_log.setLevel(logging.CRITICAL)       # trimesh logs a traceback for a missing texture
    try:
        mesh = trimesh.load(str(path), process=False, force="mesh", skip_materials=tex_missing)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise YcbvssError(f"cannot read mesh ({type(e).__name__}: {e})", path) from None
    finally:
        tm_log.setLevel(old_level)
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) == 0:
        raise YcbvssError("mesh file contains no triangle mesh", path)
    if not np.all(np.isfinite(mesh.vertices)):
        raise YcbvssError("mesh has NaN/inf vertices", path)
    if tex_missing:
        warnings.warn(f"{path}: texture file {tex.name} missing, using grey", stacklevel=2)
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.tile(
            np.array([153, 153, 153, 255], np.uint8), (len(mesh.vertices), 1)))
    if unit_scale != 1.0:
        mesh.vertices = np.asarray(mesh.vertices, dtype=np.float64) * float(unit_scale)
    return mesh


def load_textured_mm(path, unit_scale: float = 1.0):
    """(mesh with per-vertex UVs, texture RGB uint8 | None) in mm; the texture is decoded with
    OpenCV (much faster than through trimesh/PIL for 4096 px maps). Missing texture: warning."""
    path = _check_file(path, "model file")
    try:
        mesh = trimesh.load(str(path), process=False, force="mesh", skip_materials=True)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise YcbvssError(f"cannot read mesh ({type(e).__name__}: {e})", path) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) == 0:
        raise YcbvssError("mesh file contains no triangle mesh", path)
    if not np.all(np.isfinite(mesh.vertices)):
        raise YcbvssError("mesh has NaN/inf vertices", path)
    if unit_scale != 1.0:
        mesh.vertices = np.asarray(mesh.vertices, dtype=np.float64) * float(unit_scale)
    tex_path = _texture_reference(path)
    tex = None
    if tex_path is not None:
        im = cv2.imread(str(tex_path), cv2.IMREAD_COLOR) if tex_path.is_file() else None
        if im is None:
            warnings.warn(f"{path}: texture file {tex_path.name} missing or unreadable, using grey", stacklevel=2)
        else:
            tex = cv2.cvtColor(im, cv2.COLOR_BGR2RGB)
    return mesh, tex


def load_geometry_mm(path, unit_scale: float = 1.0):
    """Vertices and faces only (no texture decoding) as a ``trimesh.Trimesh`` in mm."""
    path = _check_file(path, "model file")
    try:
        mesh = trimesh.load(str(path), process=False, force="mesh", skip_materials=True)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise YcbvssError(f"cannot read mesh ({type(e).__name__}: {e})", path) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) == 0 or len(mesh.faces) == 0:
        raise YcbvssError("mesh file contains no triangle mesh", path)
    v = np.asarray(mesh.vertices, dtype=np.float64) * float(unit_scale)
    if not np.all(np.isfinite(v)):
        raise YcbvssError("mesh has NaN/inf vertices", path)
    return trimesh.Trimesh(v, np.asarray(mesh.faces), process=False)


def _ply_vertices(path: Path) -> np.ndarray:
    """Read the x/y/z of the ``vertex`` element of an ASCII or binary PLY, as stored."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                raise YcbvssError("truncated PLY header (no end_header)", path)
            line = line.decode("latin-1").strip()
            header.append(line)
            if line == "end_header":
                break
            if len(header) > 500:
                raise YcbvssError("not a PLY file (no end_header)", path)
        body_offset = f.tell()
    if not header or header[0] != "ply":
        raise YcbvssError("not a PLY file (missing 'ply' magic)", path)
    fmt = next((h.split()[1] for h in header if h.startswith("format")), None)
    # elements in order with their properties
    elems: list[tuple[str, int, list[tuple[str, ...]]]] = []
    for h in header:
        t = h.split()
        if t and t[0] == "element":
            elems.append((t[1], int(t[2]), []))
        elif t and t[0] == "property" and elems:
            elems[-1][2].append(tuple(t[1:]))
    if not elems or elems[0][0] != "vertex":
        raise YcbvssError("PLY has no leading 'vertex' element", path)
    _, n, props = elems[0]
    if any(p[0] == "list" for p in props):
        raise YcbvssError("PLY vertex element has list properties", path)
    names = [p[-1] for p in props]
    if not {"x", "y", "z"} <= set(names):
        raise YcbvssError("PLY vertices lack x/y/z", path)
    if fmt == "ascii":
        with open(path, "rb") as f:
            f.seek(body_offset)
            rows = [f.readline() for _ in range(n)]
        try:
            arr = np.array([r.split()[:len(names)] for r in rows], dtype=np.float64)
        except ValueError:
            raise YcbvssError("malformed or truncated PLY vertex data", path) from None
        if arr.shape != (n, len(names)):
            raise YcbvssError(f"truncated PLY: expected {n} vertices", path)
        cols = [names.index(c) for c in ("x", "y", "z")]
        return arr[:, cols]
    types = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
    endian = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt)
    if endian is None:
        raise YcbvssError(f"unknown PLY format {fmt!r}", path)
    try:
        dt = np.dtype([(p[-1], endian + types[p[0]]) for p in props])
    except KeyError as e:
        raise YcbvssError(f"unknown PLY property type {e}", path) from None
    data = np.fromfile(path, dtype=dt, count=n, offset=body_offset)
    if data.shape[0] != n:
        raise YcbvssError(f"truncated PLY: expected {n} vertices, got {data.shape[0]}", path)
    return np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float64)


_OBJ_V = re.compile(rb"^v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)


def _obj_vertices(path: Path) -> np.ndarray:
    """The ``v`` lines of an OBJ file, as stored (no splitting at UV seams)."""
    rows = _OBJ_V.findall(path.read_bytes())
    if not rows:
        raise YcbvssError("OBJ has no vertices", path)
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError:
        raise YcbvssError("malformed OBJ vertex line", path) from None


def load_vertices_mm(path, unit_scale: float = 1.0) -> np.ndarray:
    """All vertices as stored in the model file (no merging), (N, 3) float64 in mm.

    PLY: the ``vertex`` element; OBJ: the ``v`` lines; ``.xyz``/``.txt``: one point per line.
    These are the model points of the pose metrics, as bop_toolkit uses them.
    """
    path = _check_file(path, "model file")
    ext = path.suffix.lower()
    if ext == ".ply":
        v = _ply_vertices(path)
    elif ext == ".obj":
        v = _obj_vertices(path)
    elif ext in (".xyz", ".txt", ".pts"):
        try:
            v = np.loadtxt(path, dtype=np.float64, ndmin=2)[:, :3]
        except ValueError:
            raise YcbvssError("malformed point file", path) from None
    else:
        v = np.asarray(load_mesh_mm(path).vertices, dtype=np.float64)
    if v.size == 0:
        raise YcbvssError("model has no vertices", path)
    if not np.all(np.isfinite(v)):
        raise YcbvssError("model has NaN/inf vertices", path)
    return v * float(unit_scale)


def vertex_normals_across_seams(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, shared by all copies of a vertex duplicated at UV seams.

    (trimesh's per-vertex normals would crease along seams because the copies are not
    connected.) Returns (N, 3) float64 unit normals (0 for isolated vertices).
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    _, inv = np.unique(v, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])   # |fn| = 2 * area
    acc = np.zeros((inv.max() + 1, 3))
    for k in range(3):
        np.add.at(acc, inv[f[:, k]], fn)
    n = acc[inv]
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)


def mesh_texture_rgb(mesh) -> np.ndarray | None:
    """The texture image (H, W, 3) uint8 RGB of a TextureVisuals mesh, or None."""
    vis = getattr(mesh, "visual", None)
    mat = getattr(vis, "material", None)
    img = getattr(mat, "image", None)
    if img is None and mat is not None:
        img = getattr(mat, "baseColorTexture", None)
    if img is None:
        return None
    return np.asarray(img.convert("RGB"), dtype=np.uint8)


def mesh_uv(mesh) -> np.ndarray | None:
    uv = getattr(getattr(mesh, "visual", None), "uv", None)
    if uv is None:
        return None
    uv = np.asarray(uv, dtype=np.float64)
    return uv if uv.shape == (len(mesh.vertices), 2) else None


def write_ply_mm(path, mesh, texture_name: str | None = None,
                 texture_rgb: np.ndarray | None = None) -> None:
    """Write ``mesh`` (already in mm) as a binary PLY in the BOP model layout, atomically.

    Vertex properties x, y, z, nx, ny, nz (float32) and, when the mesh has per-vertex UVs,
    texture_u, texture_v; faces as ``list uchar int vertex_indices``. With ``texture_name``
    the header gets ``comment TextureFile <texture_name>`` and the texture (``texture_rgb``,
    else the mesh's material image) is written as PNG beside the PLY under that name (only
    when the mesh has UVs). A mesh with per-vertex colours and no UVs gets red/green/blue.
    Normals are area-weighted and shared across UV-seam duplicates.
    """
    path = Path(path)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    n = vertex_normals_across_seams(v, f)
    uv = mesh_uv(mesh)
    if texture_name is not None and texture_rgb is None:
        texture_rgb = mesh_texture_rgb(mesh)
    textured = texture_name is not None and texture_rgb is not None and uv is not None
    colors = None
    vis = getattr(mesh, "visual", None)
    if uv is None and getattr(vis, "kind", None) == "vertex":
        colors = np.asarray(vis.vertex_colors, dtype=np.uint8)[:, :3]
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if uv is not None:
        fields += [("texture_u", "<f4"), ("texture_v", "<f4")]
    if colors is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    vert = np.empty(len(v), dtype=np.dtype(fields))
    for i, c in enumerate("xyz"):
        vert[c] = v[:, i]
        vert["n" + c] = n[:, i]
    if uv is not None:
        vert["texture_u"], vert["texture_v"] = uv[:, 0], uv[:, 1]
    if colors is not None:
        vert["red"], vert["green"], vert["blue"] = colors[:, 0], colors[:, 1], colors[:, 2]
    face = np.empty(len(f), dtype=np.dtype([("n", "u1"), ("idx", "<i4", (3,))]))
    face["n"] = 3
    face["idx"] = f
    head = ["ply", "format binary_little_endian 1.0", "comment ycbvss generated (units: mm)"]
    if textured:
        head.append(f"comment TextureFile {texture_name}")
    head.append(f"element vertex {len(v)}")
    head += [f"property {'uchar' if dt == 'u1' else 'float'} {name}" for name, dt in fields]
    head += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    if textured:
        bgr = cv2.cvtColor(np.ascontiguousarray(texture_rgb[..., :3]), cv2.COLOR_RGB2BGR)
        with atomic_path(path.parent / texture_name, ".png") as tmp:   # fast: level 1 + RLE
            if not cv2.imwrite(str(tmp), bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1,
                                               cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_RLE]):
                raise YcbvssError("PNG encoder failed", path.parent / texture_name)
    with atomic_path(path, ".ply") as tmp:
        with open(tmp, "wb") as fh:
            fh.write(("\n".join(head) + "\n").encode("ascii"))
            fh.write(vert.tobytes())
            fh.write(face.tobytes())


def diameter_mm(vertices: np.ndarray) -> float:
    """Largest distance between two vertices (exact: searched over the convex hull vertices)."""
    v = np.asarray(vertices, np.float64)
    try:
        hv = v[ConvexHull(v).vertices]
    except (QhullError, ValueError):   # degenerate (flat) point sets
        hv = v
    if len(hv) > 20000:
        hv = hv[:: int(np.ceil(len(hv) / 20000))]
    return float(pdist(hv).max()) if len(hv) > 1 else 0.0


def compute_models_info(mesh_mm, symmetries_discrete: list | None = None,
                        symmetries_continuous: list | None = None) -> dict:
    """One BOP models_info entry: diameter, min_x/y/z, size_x/y/z (+ symmetries if given).

    ``mesh_mm``: a trimesh (or an (N, 3) vertex array) in mm. ``symmetries_discrete``: list of
    4x4 matrices (or 16-lists, row-major, translation mm); ``symmetries_continuous``: list of
    ``{"axis": [3], "offset": [3]}``.
    """
    v = np.asarray(getattr(mesh_mm, "vertices", mesh_mm), dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    info = {"diameter": round(diameter_mm(v), 6)}
    for i, c in enumerate("xyz"):
        info[f"min_{c}"] = round(float(lo[i]), 6)
    for i, c in enumerate("xyz"):
        info[f"size_{c}"] = round(float(hi[i] - lo[i]), 6)
    if symmetries_discrete:
        info["symmetries_discrete"] = [np.asarray(S, np.float64).reshape(-1).tolist()
                                       for S in symmetries_discrete]
    if symmetries_continuous:
        info["symmetries_continuous"] = [{"axis": [float(a) for a in s["axis"]],
                                          "offset": [float(o) for o in s.get("offset", (0, 0, 0))]}
                                         for s in symmetries_continuous]
    return info
