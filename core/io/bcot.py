"""Reader and writer of the BCOT layout (Li et al., "BCOT: A Markerless High-Precision 3D Object
Tracking Benchmark", CVPR 2022), and a generator of small BCOT-format fixtures.

::

    ROOT/<scene>/K.txt                 Matx33f K = Matx33f(fx, 0, cx, 0, fy, cy, 0, 0, 1);
    ROOT/<scene>/<body>/pose.txt       one line per frame: r11 r12 r13 r21 r22 r23 r31 r32 r33 tx ty tz
                                       (object-to-camera, R row-major, t in mm)
    ROOT/<scene>/<body>/NNNN.png       the frames, line k of pose.txt = k-th image in numeric order
    ROOT/models/<body>.obj             the body's mesh (mm)

A *sequence* is one (scene, body) folder. Scene names are BCOT's capture conditions
(``complex_movable_handheld``, ``outdoor_scene1_movable_suspension_cam2``, ...), body names the 20
objects (``3D Touch``, ``Ape``, ...). In ycbvss a sequence becomes one :class:`ycbvss.scene.Scene`
whose ``scene_id`` is its index in the sorted list of all (scene, body) folders of the root, and a
body's ``obj_id`` is its 1-based index in :data:`BCOT_BODY_NAMES` (unknown bodies follow, sorted).
Only the pose files and K.txt are read to list frames and GT; images stay on disk.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Iterable

import numpy as np
from PIL import Image

from ..camera import Camera, check_K
from ..errors import YcbvssError
from ..geometry.so3 import exp_so3, orthonormality_error
from ..render import Renderer
from ..scene import Dataset, Frame, Instance, ObjectModel, Scene
from .atomic import atomic_path, write_text_atomic
from .images import write_png
from .mesh import load_textured_mm

BCOT_BODY_NAMES = (
    "3D Touch", "Ape", "Auto GPS", "Bracket", "Cat", "Deadpool", "Driller", "FlashLight", "Jack",
    "Lamp Clamp", "RJ45 Clip", "Squirrel", "Standtube", "Stitch", "Teapot", "Vampire Queen", "RTI Arm",
    "Wall Shelf", "Lego", "Tube",
)
BCOT_SCENE_NAMES = (
    "complex_movable_handheld", "complex_movable_suspension", "complex_static_handheld",
    "complex_static_suspension", "complex_static_trans", "easy_static_handheld", "easy_static_suspension",
    "easy_static_trans", "light_movable_handheld", "light_movable_suspension", "light_static_handheld",
    "light_static_suspension", "light_static_trans", "occlusion_movable_suspension",
    "outdoor_scene1_movable_handheld_cam1", "outdoor_scene1_movable_handheld_cam2",
    "outdoor_scene1_movable_suspension_cam1", "outdoor_scene1_movable_suspension_cam2",
    "outdoor_scene2_movable_handheld_cam1", "outdoor_scene2_movable_handheld_cam2",
    "outdoor_scene2_movable_suspension_cam1", "outdoor_scene2_movable_suspension_cam2",
)
# The paper tests on 11 BCOT scenes but did not publish which. ycbvss's default test split: every
# capture condition (complex/easy/light/occlusion/outdoor, movable/static, handheld/suspension/trans)
# at least once, one camera per outdoor pair. Override with --bcot-scenes; the JSON records the list.
BCOT_TEST_SCENES = (
    "complex_movable_handheld", "complex_static_suspension", "complex_static_trans",
    "easy_static_handheld", "light_movable_suspension", "light_static_handheld", "light_static_trans",
    "occlusion_movable_suspension", "outdoor_scene1_movable_handheld_cam1",
    "outdoor_scene1_movable_suspension_cam1", "outdoor_scene2_movable_handheld_cam1",
)
ROT_TOL = 1e-3
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_IMG_RE = re.compile(r"^(\d+)\.png$")


def is_bcot_root(root: str | Path) -> bool:
    """A folder with ``models/*.obj`` and at least one ``<scene>/K.txt``."""
    root = Path(root)
    return (root / "models").is_dir() and any(root.glob("models/*.obj")) and any(root.glob("*/K.txt"))


def read_K_txt(path: str | Path) -> np.ndarray:
    """``K.txt`` (``Matx33f K = Matx33f(fx, 0, cx, 0, fy, cy, 0, 0, 1);``, or 9 plain numbers) -> 3x3."""
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("missing K.txt", path)
    text = path.read_text(encoding="utf-8", errors="replace")
    m = re.search(r"\(([^()]*)\)", text)
    nums = re.findall(_NUM, m.group(1) if m else text)
    if len(nums) != 9:
        raise YcbvssError(f"expected 9 numbers (Matx33f(fx, 0, cx, 0, fy, cy, 0, 0, 1)), found {len(nums)}", path)
    return check_K(np.array([float(x) for x in nums], dtype=np.float64).reshape(3, 3), str(path))


def format_K_txt(K: np.ndarray) -> str:
    """The C++ line BCOT writes."""
    k = np.asarray(K, dtype=np.float64).reshape(9)
    return "Matx33f K = Matx33f(" + ", ".join(f"{v:.6f}".rstrip("0").rstrip(".") if v != 0 else "0"
                                            for v in k) + ");\n"


def read_pose_txt(path: str | Path, where: str = "", rot_tol: float = ROT_TOL) -> np.ndarray:
    """``pose.txt`` -> (N, 4, 4) object-to-camera poses (mm). Errors name the file, line and frame."""
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("missing pose.txt", path, where or None)
    out = []
    for ln, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            v = np.array([float(x) for x in line.replace(",", " ").split()], dtype=np.float64)
        except ValueError:
            raise YcbvssError(f"line {ln}: not numbers", path, f"{where} frame {len(out)}".strip()) from None
        if v.size != 12 or not np.all(np.isfinite(v)):
            raise YcbvssError(f"line {ln}: expected 12 finite numbers (R row-major, t mm), got {v.size}", path,
                              f"{where} frame {len(out)}".strip())
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = v[:9].reshape(3, 3), v[9:]
        err = orthonormality_error(T[:3, :3])
        if err > rot_tol:
            raise YcbvssError(f"line {ln}: R is not orthonormal (|R^T R - I| = {err:.3g})", path,
                              f"{where} frame {len(out)}".strip())
        out.append(T)
    if not out:
        raise YcbvssError("pose.txt has no pose", path, where or None)
    return np.array(out)


def format_pose_txt(poses: Iterable[np.ndarray]) -> str:
    lines = []
    for T in poses:
        T = np.asarray(T, dtype=np.float64)
        lines.append(" ".join(f"{x:.9g}" for x in np.r_[T[:3, :3].reshape(9), T[:3, 3]]))
    return "\n".join(lines) + "\n"


def body_obj_ids(body_names: Iterable[str]) -> dict[str, int]:
    """body name -> obj_id (1-based index in :data:`BCOT_BODY_NAMES`; unknown bodies after, sorted)."""
    known = {n: i + 1 for i, n in enumerate(BCOT_BODY_NAMES)}
    out = {n: known[n] for n in body_names if n in known}
    nxt = len(BCOT_BODY_NAMES) + 1
    for n in sorted(set(body_names) - set(known)):
        out[n] = nxt
        nxt += 1
    return out


def list_sequences(root: str | Path) -> list[tuple[str, str]]:
    """All (scene, body) folders that hold a pose.txt, sorted."""
    root = Path(root)
    if not root.is_dir():
        raise YcbvssError("BCOT root not found", root)
    seqs = sorted((p.parent.parent.name, p.parent.name) for p in root.glob("*/*/pose.txt")
                  if (p.parent.parent / "K.txt").is_file())
    if not seqs:
        raise YcbvssError("no BCOT sequence (<scene>/<body>/pose.txt with <scene>/K.txt) found", root)
    return seqs


def list_images(seq_dir: Path) -> list[Path]:
    """The ``NNNN.png`` frames of a sequence folder in numeric order."""
    ims = [(int(m.group(1)), p) for p in seq_dir.iterdir() if (m := _IMG_RE.match(p.name))]
    return [p for _, p in sorted(ims)]


def load_bcot_models(root: str | Path, bodies: Iterable[str] | None = None) -> dict[int, ObjectModel]:
    """``models/<body>.obj`` (mm) as ObjectModels keyed by obj_id (see :func:`body_obj_ids`)."""
    root = Path(root)
    mdir = root / "models"
    names = sorted(p.stem for p in mdir.glob("*.obj")) if bodies is None else sorted(set(bodies))
    ids = body_obj_ids(set(names) | {p.stem for p in mdir.glob("*.obj")})
    models = {}
    for n in names:
        p = mdir / f"{n}.obj"
        if not p.is_file():
            raise YcbvssError("missing model file", p, f"body {n!r}")
        models[ids[n]] = ObjectModel(obj_id=ids[n], path=p, name=n, unit_scale=1.0)
    return models


def _image_size(path: Path | None, default=(640, 480)) -> tuple[int, int]:
    if path is None:
        return default
    try:
        with Image.open(path) as im:
            return int(im.size[0]), int(im.size[1])
    except OSError as e:
        raise YcbvssError(f"unreadable image: {e}", path) from None


def load_bcot_sequence(root: str | Path, scene: str, body: str, scene_id: int, obj_id: int,
                       need_images: bool = False) -> Scene:
    """One (scene, body) sequence: frames 0..N-1 (line k of pose.txt = k-th image, numerically sorted).

    Without ``need_images`` only pose.txt and K.txt are read (frames have ``rgb_path`` when the
    image exists); with it, a missing image or a count mismatch is an error."""
    root = Path(root)
    sdir = root / scene / body
    wh = f"sequence {scene}/{body}"
    K = read_K_txt(root / scene / "K.txt")
    poses = read_pose_txt(sdir / "pose.txt", wh)
    ims = list_images(sdir) if sdir.is_dir() else []
    if ims and len(ims) != len(poses):
        raise YcbvssError(f"{len(ims)} images but {len(poses)} poses", sdir / "pose.txt", wh)
    if need_images and not ims:
        raise YcbvssError("sequence has no NNNN.png images", sdir, wh)
    w, h = _image_size(ims[0] if ims else None)
    cam = Camera(K, w, h)
    frames = [Frame(scene_id=scene_id, im_id=k, camera=cam, instances=[Instance(obj_id=obj_id, T_m2c=T, gt_id=0)],
                    rgb_path=ims[k] if ims else None, extra={"sequence": f"{scene}/{body}"})
              for k, T in enumerate(poses)]
    return Scene(scene_id=scene_id, frames=frames, root=sdir)


def load_bcot_dataset(root: str | Path, scenes: Iterable[str] | None = None) -> Dataset:
    """A BCOT root as a streaming Dataset: one ycbvss scene per (scene, body) sequence.

    ``scenes``: BCOT scene names to keep (None: all). ``dataset.sequence_names`` maps scene_id to
    ``"scene/body"``; ids are stable: indices into all sequences of the root."""
    root = Path(root)
    seqs = list_sequences(root)
    if scenes is not None:
        want = list(scenes)
        have = {s for s, _ in seqs}
        missing = [s for s in want if s not in have]
        if missing:
            raise YcbvssError(f"BCOT scene {missing[0]!r} not found (have: {sorted(have)})", root / missing[0])
    models = load_bcot_models(root, {b for _, b in seqs})
    ids = body_obj_ids({b for _, b in seqs} | {p.stem for p in (root / "models").glob("*.obj")})
    index = {sb: i for i, sb in enumerate(seqs)}
    keep = [index[sb] for sb in seqs if scenes is None or sb[0] in set(scenes)]

    def loader(sid: int) -> Scene:
        s, b = seqs[sid]
        return load_bcot_sequence(root, s, b, sid, ids[b])

    ds = Dataset(root, models, keep, loader, name="bcot", split="")
    ds.sequence_names = {i: f"{s}/{b}" for i, (s, b) in enumerate(seqs)}
    return ds


# --------------------------------------------------------------------------- writer / fixture
def write_bcot_sequence(root: str | Path, scene: str, body: str, K: np.ndarray, poses: list[np.ndarray],
                        images: list[np.ndarray] | None = None) -> Path:
    """Write one sequence (K.txt, pose.txt and ``NNNN.png`` images, RGB uint8) atomically per file."""
    root = Path(root)
    write_text_atomic(root / scene / "K.txt", format_K_txt(K))
    sdir = root / scene / body
    write_text_atomic(sdir / "pose.txt", format_pose_txt(poses))
    for k, img in enumerate(images or []):
        write_png(sdir / f"{k:04d}.png", img)
    return sdir


def fixture_poses(n_frames: int, distance_mm: float, rng: np.random.Generator, speed_deg: float = 3.0,
                  speed_mm: float = 6.0) -> list[np.ndarray]:
    """A fast, smooth object motion (BCOT-like): random rotation drift plus a lateral wobble."""
    R = exp_so3(rng.normal(size=3))
    w = rng.normal(size=3)
    w *= np.radians(speed_deg) / np.linalg.norm(w)
    out = []
    for k in range(n_frames):
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = [speed_mm * 8 * np.sin(0.11 * k), speed_mm * 5 * np.sin(0.07 * k + 1.0),
                    distance_mm + speed_mm * 6 * np.sin(0.05 * k)]
        out.append(T)
        R = exp_so3(w + 0.2 * np.radians(speed_deg) * rng.normal(size=3)) @ R
    return out


def make_bcot_fixture(out: str | Path, mesh_path: str | Path, body: str = "Cat",
                      scenes: tuple[str, ...] = ("easy_static_handheld", "light_movable_suspension"),
                      n_frames: int = 12, width: int = 320, height: int = 240, unit_scale: float = 1000.0,
                      seed: int = 0) -> Path:
    """A small BCOT-layout dataset: ``body`` (the mesh at ``mesh_path``, scaled to mm by
    ``unit_scale``) moving in each of ``scenes``, frames rendered with the fast renderer (textured,
    headlight-shaded) over a grey background. Deterministic for ``seed``. Returns ``out``."""
    out = Path(out)
    mesh, tex = load_textured_mm(mesh_path, unit_scale)
    v, fc = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    obj = "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in v) + "".join(
        f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in fc)
    with atomic_path(out / "models" / f"{body}.obj") as tmp:
        tmp.write_text(obj)
    gl = Renderer()
    try:
        gl.add_mesh(body, mesh, tex)
        rng = np.random.default_rng(seed)
        f = 0.9 * width
        K = np.array([[f, 0, width / 2 - 0.5], [0, f, height / 2 - 0.5], [0, 0, 1.0]])
        diam = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
        for scene in scenes:
            poses = fixture_poses(n_frames, 3.0 * diam * f / width * 1.2, rng)
            imgs = []
            for T in poses:
                r = gl.render(K, width, height, [(body, T)], outputs=("color", "instance"), shade=0.6)
                img = np.full((height, width, 3), 96, np.uint8)
                m = r.instance > 0
                img[m] = r.color[m]
                imgs.append(img)
            write_bcot_sequence(out, scene, body, K, poses, imgs)
    finally:
        gl.release()
    return out
