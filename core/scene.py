"""The one data model every stage passes along: models, frames, scenes, datasets.

- Poses ``T_m2c`` are object-to-camera 4x4 float64 matrices, translation in **millimetres**,
  expressed in the frame of the :class:`ObjectModel` they refer to.
- Camera poses ``T_w2c`` (optional) are world-to-camera 4x4, millimetres.
- Images are *not* held in memory: a :class:`Frame` holds paths and loads on demand, so a
  dataset of 134k frames streams scene by scene.

Readers (``ycbvss.io.bop``, ``ycbvss.io.ycbv``) build these objects; writers consume them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from .camera import Camera
from .io.images import read_depth_mm, read_label, read_rgb
from .io.mesh import load_mesh_mm, load_vertices_mm


@dataclass
class ObjectModel:
    """A 3D model of one object class.

    ``obj_id``: BOP id (= YCB-Video class index, 1..21). ``path``: mesh file (PLY/OBJ).
    ``unit_scale``: factor that converts the file's length unit to millimetres (1 for BOP PLY
    in mm, 1000 for YCB-Video OBJ in metres). ``symmetries_discrete``: list of 4x4 (mm);
    ``symmetries_continuous``: list of dicts ``{"axis": [3], "offset": [3] (mm)}`` (BOP format).
    ``symmetric``: use ADD-S for this object in the ADD(-S) protocol. ``rest_points_mm``: optional
    (N, 3) points (mm, this model's frame) of another model of the same object whose convex hull
    gives its resting faces (:mod:`ycbvss.refine.table_rest`) instead of this mesh's hull.
    """

    obj_id: int
    path: Path | None = None
    name: str = ""
    unit_scale: float = 1.0
    diameter_mm: float | None = None
    symmetries_discrete: list = field(default_factory=list)
    symmetries_continuous: list = field(default_factory=list)
    symmetric: bool = False
    textureless: bool = False
    info: dict = field(default_factory=dict)
    rest_points_mm: object | None = field(default=None, repr=False)
    _mesh: object | None = field(default=None, repr=False)
    _loader: Callable | None = field(default=None, repr=False)

    @property
    def mesh(self):
        """The model as a ``trimesh.Trimesh`` in millimetres (loaded lazily, cached)."""
        if self._mesh is None:
            if self._loader is None:
                self._mesh = load_mesh_mm(self.path, self.unit_scale)
            else:
                self._mesh = self._loader()
        return self._mesh

    @mesh.setter
    def mesh(self, value):
        self._mesh = value

    @cached_property
    def vertices_mm(self) -> np.ndarray:
        """All vertices as stored in the model file (no merging), (N, 3) float64, mm.

        These are the model points of the metrics, as bop_toolkit uses them."""
        if self._mesh is not None and self.path is None:
            return np.asarray(self._mesh.vertices, dtype=np.float64)
        return load_vertices_mm(self.path, self.unit_scale)

    @property
    def label(self) -> str:
        return self.name or f"obj_{self.obj_id:06d}"


@dataclass
class Instance:
    """One annotated (or estimated) object instance in a frame."""

    obj_id: int
    T_m2c: np.ndarray
    gt_id: int | None = None
    score: float = 1.0

    @property
    def R(self) -> np.ndarray:
        return self.T_m2c[:3, :3]

    @property
    def t_mm(self) -> np.ndarray:
        return self.T_m2c[:3, 3]


@dataclass
class Frame:
    """One image of a scene, with its camera and object instances. Images load on demand."""

    scene_id: int
    im_id: int
    camera: Camera
    instances: list[Instance] = field(default_factory=list)
    depth_scale: float = 1.0          # depth image value * depth_scale = mm (BOP convention)
    rgb_path: Path | None = None
    depth_path: Path | None = None
    label_path: Path | None = None    # YCB-Video label image (pixel value = obj_id), optional
    T_w2c: np.ndarray | None = None   # world-to-camera (mm), optional
    extra: dict = field(default_factory=dict)

    def load_rgb(self) -> np.ndarray:
        """RGB image (H, W, 3) uint8."""
        return read_rgb(self.rgb_path, where=self.where)

    def load_depth_mm(self) -> np.ndarray:
        """Depth (H, W) float32 in mm, 0 where invalid."""
        return read_depth_mm(self.depth_path, self.depth_scale, where=self.where)

    def load_label(self) -> np.ndarray:
        """Label image (H, W) uint8/uint16 with obj_id per pixel (0 = background)."""
        return read_label(self.label_path, where=self.where)

    @property
    def where(self) -> str:
        return f"scene {self.scene_id} frame {self.im_id}"

    def instance(self, obj_id: int) -> Instance | None:
        for inst in self.instances:
            if inst.obj_id == obj_id:
                return inst
        return None


@dataclass
class Scene:
    """A sequence of frames of one static scene (a YCB-Video video / a BOP scene folder)."""

    scene_id: int
    frames: list[Frame] = field(default_factory=list)
    root: Path | None = None

    @property
    def obj_ids(self) -> list[int]:
        return sorted({i.obj_id for f in self.frames for i in f.instances})

    def frame(self, im_id: int) -> Frame:
        for f in self.frames:
            if f.im_id == im_id:
                return f
        raise KeyError(f"scene {self.scene_id} has no frame {im_id}")


class Dataset:
    """A dataset (BOP split or YCB-Video root): models plus scenes, streamed scene by scene.

    Subclasses / readers provide ``scene_ids`` and ``load_scene(scene_id)``.
    """

    def __init__(self, root: Path, models: dict[int, ObjectModel], scene_ids: list[int],
                 scene_loader: Callable[[int], Scene], name: str = "", split: str = ""):
        self.root = Path(root)
        self.models = models
        self.scene_ids = list(scene_ids)
        self._scene_loader = scene_loader
        self.name = name
        self.split = split

    def load_scene(self, scene_id: int) -> Scene:
        return self._scene_loader(scene_id)

    def iter_scenes(self, scene_ids: list[int] | None = None) -> Iterator[Scene]:
        for sid in (self.scene_ids if scene_ids is None else scene_ids):
            yield self.load_scene(sid)

    def __repr__(self) -> str:
        return (f"Dataset({self.name!r}, root={str(self.root)!r}, split={self.split!r}, "
                f"{len(self.models)} models, {len(self.scene_ids)} scenes)")
