"""Headless offscreen rasteriser: depth (mm), instance ids, camera-frame normals, textured colour, per-item masks.

Usage::

    r = Renderer()
    r.add_mesh("obj_000001", mesh_mm)                    # upload once (trimesh, millimetres)
    out = r.render(K, 640, 480, [("obj_000001", T_m2c)], outputs=("depth", "instance"))
    out.depth_mm, out.instance

One moderngl context per process (EGL, Mesa llvmpipe without a GPU), GPU buffers per mesh key, textures
and framebuffers (per size and output set) are created once and reused.  Only requested outputs are read back.
Not thread-safe (one Renderer per process/thread).
"""
from __future__ import annotations

import os
import warnings
from collections import OrderedDict
from collections.abc import Collection, Hashable, Sequence
from dataclasses import dataclass, field

import cv2
import moderngl
import numpy as np

from ..camera import check_K
from ..errors import YcbvssError
from .context import get_context, gil_free_gl
from .projection import FRONT_FACE, projection_from_K
from .shaders import sources
from .texture import (
    first_use_order,
    is_closed_outward,
    merge_coincident,
    mesh_texture,
    mesh_vertex_colors,
    smooth_vertex_normals,
    spatial_order,
)

OUTPUTS = ("depth", "instance", "normal", "color", "mask_all", "back_depth")
GREY = 0.6


@dataclass
class RenderOutput:
    """Rendered images (only the requested ones are set; others are None).

    ``depth_mm`` (H, W) float32 camera z in mm, 0 on background; ``instance`` (H, W) int32, k+1 where
    ``items[k]`` is the front-most surface, 0 on background; ``normal_cam`` (H, W, 3) float32 unit normals in
    the camera frame, interpolated smooth vertex normals (seam duplicates merged), flipped towards the camera
    on back faces of open meshes, 0 on background; ``color`` (H, W, 3) uint8 RGB albedo (texture, vertex
    colour or grey 0.6; 0 on background); ``masks_all`` / ``depth_all_mm``:
    per-item unoccluded silhouettes (bool) and depths (float32, 0 outside), with ``"mask_all"``;
    ``back_depth_mm`` / ``back_instance``: camera z (mm) and item (k+1) of the nearest *back-facing*
    surface of each pixel (front faces culled; 0 where none), with ``"back_depth"``: where a ray enters an
    object at ``depth_mm`` it leaves it at ``back_depth_mm`` (closed meshes).
    """

    depth_mm: np.ndarray | None = None
    instance: np.ndarray | None = None
    normal_cam: np.ndarray | None = None
    color: np.ndarray | None = None
    masks_all: list[np.ndarray] | None = None
    depth_all_mm: list[np.ndarray] | None = None
    back_depth_mm: np.ndarray | None = None
    back_instance: np.ndarray | None = None

    @property
    def mask(self) -> np.ndarray | None:
        """(H, W) bool union of all visible surfaces (from depth or instance)."""
        if self.instance is not None:
            return self.instance > 0
        if self.depth_mm is not None:
            return self.depth_mm > 0
        return None


@dataclass
class _GpuMesh:
    n_faces: int
    cull: bool = False                          # closed, outward-oriented: back faces may be culled
    vbos: dict = field(default_factory=dict)     # name -> moderngl.Buffer
    ibo: object = None
    ibo_merged: object = None                   # indices into vbos["in_pos_merged"] (geometry-only passes)
    index_size: int = 4
    index_size_merged: int = 4
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))  # bounding sphere (model frame, mm)
    radius: float = 0.0
    texture: object = None                      # moderngl.Texture (1x1 white when untextured)
    vaos: dict = field(default_factory=dict)     # variant -> moderngl.VertexArray

    def release(self):
        for vao in self.vaos.values():
            vao.release()
        for b in self.vbos.values():
            b.release()
        for b in (self.ibo, self.ibo_merged):
            if b is not None:
                b.release()
        if self.texture is not None:
            self.texture.release()


def _mesh_arrays(key: Hashable, mesh_mm) -> tuple[np.ndarray, np.ndarray]:
    """(V (N, 3) float32 mm, F (M, 3)) of a triangle mesh; YcbvssError if not a valid one."""
    V = np.asarray(getattr(mesh_mm, "vertices", None) if mesh_mm is not None else None, dtype=np.float32)
    F = np.asarray(getattr(mesh_mm, "faces", None) if mesh_mm is not None else None)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise YcbvssError(f"add_mesh: mesh for key {key!r} must be a triangle mesh with (N,3) vertices "
                          f"and (M,3) faces", where="ycbvss.render")
    if not np.all(np.isfinite(V)):
        raise YcbvssError(f"add_mesh: mesh for key {key!r} has non-finite vertices", where="ycbvss.render")
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        raise YcbvssError(f"add_mesh: mesh for key {key!r} has face indices out of range",
                          where="ycbvss.render")
    return V, F


def _vertex_attributes(key: Hashable, mesh_mm, n: int, texture_rgb: np.ndarray | None) -> tuple:
    """Per-vertex (UV (n, 2) float32 in GL convention, colours (n, 3) float32, normals (n, 3)) and
    the texture image (H, W, >=3) uint8 to use, or None when the mesh is not textured."""
    uv, image = mesh_texture(mesh_mm)
    if texture_rgb is not None:
        image = np.asarray(texture_rgb)
        if image.ndim != 3 or image.shape[2] < 3 or image.dtype != np.uint8:
            raise YcbvssError(f"add_mesh: texture for key {key!r} must be (H,W,3) uint8, got "
                              f"{image.shape} {image.dtype}", where="ycbvss.render")
        if uv is None:
            warnings.warn(f"add_mesh: texture given for mesh {key!r} without UV; rendering it grey",
                          stacklevel=3)
    vcol = mesh_vertex_colors(mesh_mm)
    textured = uv is not None and image is not None
    if vcol is None:
        vcol = np.full((n, 3), 1.0 if textured else GREY, dtype=np.float32)
    if uv is None:
        uv_gl = np.zeros((n, 2), dtype=np.float32)
    else:
        uv_gl = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)  # image row 0 = t 0
    normals = smooth_vertex_normals(mesh_mm)
    return uv_gl, vcol, normals, (image if textured else None)


_GL_SRGB8 = 0x8C41                 # GL_SRGB8: an sRGB-encoded RGB texture, decoded to linear light when sampled


class Renderer:
    """Offscreen OpenGL renderer of (mesh, pose) lists with mutual occlusion.

    ``max_texture_px``: textures larger than this (longest side) are downsampled (INTER_AREA) before upload;
    YCB textures are 4096 px while objects cover a few hundred pixels, so 2048 keeps the same look with a
    quarter of the memory.  ``mipmap``: mipmapped texture sampling (no aliasing when minified).
    ``srgb_textures``: textures are uploaded as sRGB textures, so GL filters and mip-averages them in
    linear light, as a camera integrates light (and Cycles filters its sRGB image textures); the
    colour output keeps its sRGB encoding. False (default): filtered on the encoded values, which
    darkens a contrasted texture where it is minified (at grazing angles, e.g. towards a silhouette).
    ``cull_back_faces``: skip back-facing triangles (about 2x faster on llvmpipe). ``"auto"`` (default) culls
    only meshes found closed (no boundary edge once seam duplicates are merged), consistently wound and
    outward oriented, where culling cannot change the image (unless the camera is inside the object);
    ``True`` culls every mesh, ``False`` none.
    """

    def __init__(self, max_texture_px: int = 2048, mipmap: bool = True, cull_back_faces: bool | str = "auto",
                 max_cached_framebuffers: int = 8, srgb_textures: bool = False):
        self.ctx = get_context()
        self._pid = os.getpid()
        self._max_viewport = int(min(self.ctx.info.get("GL_MAX_VIEWPORT_DIMS", (16384, 16384))))
        self.max_texture_px = int(max_texture_px)
        self.mipmap = bool(mipmap)
        self.srgb_textures = bool(srgb_textures)
        if cull_back_faces not in (True, False, "auto"):
            raise YcbvssError(f"Renderer: cull_back_faces must be True, False or 'auto', got {cull_back_faces!r}",
                              where="ycbvss.render")
        self.cull_back_faces = cull_back_faces
        self._meshes: dict[Hashable, _GpuMesh] = {}
        # key -> the object a key was made from (add_mesh(owner=)): held so that a key built from id(owner)
        # is never matched by another object that Python later puts at the same address
        self._owners: dict[Hashable, object] = {}
        self._programs: dict[tuple[bool, bool], object] = {}
        self._fbos: OrderedDict = OrderedDict()
        self._max_fbos = int(max_cached_framebuffers)
        self._white = None
        self._nocull: set[int] = set()

    # ------------------------------------------------------------------ meshes
    def has_mesh(self, key: Hashable) -> bool:
        return key in self._meshes

    def has_mesh_of(self, key: Hashable, owner: object) -> bool:
        """``key`` is uploaded and was added for this very ``owner`` object (see :meth:`add_mesh`)."""
        return key in self._meshes and self._owners.get(key) is owner

    def mesh_keys(self) -> list:
        return list(self._meshes)

    def add_mesh(self, key: Hashable, mesh_mm, texture_rgb: np.ndarray | None = None, owner: object = None) -> None:
        """Upload a trimesh mesh (vertices in mm) under ``key`` (re-adding a key replaces it).
        ``owner``: the object the key was made from (e.g. a model whose ``id`` is part of the key); it is
        kept referenced while the mesh is, and :meth:`has_mesh_of` matches only it.

        Colour: ``texture_rgb`` (H, W, 3) uint8 with the mesh's UV if given, else the mesh's own texture
        (TextureVisuals), else its vertex colours (ColorVisuals), else grey 0.6.
        """
        V, F = _mesh_arrays(key, mesh_mm)
        if key in self._meshes:
            self.remove_mesh(key)
        uv_gl, vcol, normals, image = _vertex_attributes(key, mesh_mm, len(V), texture_rgb)
        cull = is_closed_outward(V, F)
        # locality order (faces by Z-order of centroids, vertices by first use): same images, faster raster
        _, vorder, F = spatial_order(V, F)
        V, normals, uv_gl, vcol = V[vorder], normals[vorder], uv_gl[vorder], vcol[vorder]
        Vm, Fm, _ = merge_coincident(V, F)
        Vm, Fm = first_use_order(Vm, Fm)
        g = _GpuMesh(n_faces=len(F), cull=cull)
        if len(V):
            lo, hi = V.min(0).astype(np.float64), V.max(0).astype(np.float64)
            g.centre = 0.5 * (lo + hi)
            g.radius = float(np.linalg.norm(V - g.centre, axis=1).max()) * (1 + 1e-6) + 1e-6
        self._upload_buffers(g, (V, F), (Vm, Fm), normals, uv_gl, vcol)
        g.texture = self._upload_texture(image[..., :3]) if image is not None else None
        self._meshes[key] = g
        if owner is not None:
            self._owners[key] = owner

    def _upload_buffers(self, g: _GpuMesh, mesh: tuple, merged: tuple, normals, uv_gl, vcol) -> None:
        """Vertex buffers (positions, merged positions, normals, UV, colours) and the index buffers of
        ``mesh`` = (V (N, 3) mm, F (M, 3)) and its coincident-vertex-merged copy ``merged``."""
        (V, F), (Vm, Fm) = mesh, merged
        ctx = self.ctx
        g.vbos = {
            "in_pos_merged": ctx.buffer(np.ascontiguousarray(Vm, dtype=np.float32).tobytes()),
            "in_pos": ctx.buffer(np.ascontiguousarray(V, dtype=np.float32).tobytes()),
            "in_nrm": ctx.buffer(np.ascontiguousarray(normals, dtype=np.float32).tobytes()),
            "in_uv": ctx.buffer(np.ascontiguousarray(uv_gl).tobytes()),
            "in_col": ctx.buffer(np.ascontiguousarray(vcol, dtype=np.float32).tobytes()),
        }
        g.index_size = 2 if len(V) < 65536 else 4
        g.index_size_merged = 2 if len(Vm) < 65536 else 4
        itype = {2: np.uint16, 4: np.uint32}
        g.ibo = ctx.buffer(np.ascontiguousarray(F, dtype=itype[g.index_size]).tobytes()) if len(F) else None
        g.ibo_merged = (ctx.buffer(np.ascontiguousarray(Fm, dtype=itype[g.index_size_merged]).tobytes())
                        if len(F) else None)

    def remove_mesh(self, key: Hashable) -> None:
        self._owners.pop(key, None)
        g = self._meshes.pop(key, None)
        if g is not None:
            g.release()

    def release(self) -> None:
        """Free all GPU objects of this renderer (the shared context stays)."""
        for k in list(self._meshes):
            self.remove_mesh(k)
        for fb in self._fbos.values():
            _release_fbo(fb)
        self._fbos.clear()
        for p in self._programs.values():
            p.release()
        self._programs.clear()
        if self._white is not None:
            self._white.release()
            self._white = None

    def _upload_texture(self, image: np.ndarray):
        H, W = image.shape[:2]
        s = self.max_texture_px / max(H, W)
        if s < 1.0:
            image = cv2.resize(image, (max(1, round(W * s)), max(1, round(H * s))), interpolation=cv2.INTER_AREA)
        H, W = image.shape[:2]
        tex = self.ctx.texture((W, H), 3, np.ascontiguousarray(image, dtype=np.uint8).tobytes(), alignment=1,
                               internal_format=_GL_SRGB8 if self.srgb_textures else None)
        tex.repeat_x = tex.repeat_y = True
        if self.mipmap:
            tex.build_mipmaps()
            # bilinear in the nearest mip level: ~25 % cheaper than trilinear on llvmpipe, same look
            tex.filter = (moderngl.LINEAR_MIPMAP_NEAREST, moderngl.LINEAR)
        else:
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        return tex

    def _white_texture(self):
        if self._white is None:
            self._white = self.ctx.texture((1, 1), 3, bytes([255, 255, 255]), alignment=1)
        return self._white

    # ------------------------------------------------------------------ GL objects
    def _program(self, with_color: bool, with_normal: bool):
        key = (with_color, with_normal)
        if key not in self._programs:
            vs, fs = sources(with_color, with_normal, self.srgb_textures)
            self._programs[key] = self.ctx.program(vertex_shader=vs, fragment_shader=fs)
        return self._programs[key]

    def _vao(self, g: _GpuMesh, with_color: bool, with_normal: bool):
        key = (with_color, with_normal)
        if key not in g.vaos:
            prog = self._program(with_color, with_normal)
            if not (with_color or with_normal):  # positions only: seam duplicates merged (fewer vertices)
                g.vaos[key] = self.ctx.vertex_array(prog, [(g.vbos["in_pos_merged"], "3f", "in_pos")],
                                                    g.ibo_merged, index_element_size=g.index_size_merged)
                return g.vaos[key]
            names = ["in_pos"] + (["in_nrm"] if with_normal else []) + (["in_uv", "in_col"] if with_color else [])
            fmts = {"in_pos": "3f", "in_nrm": "3f", "in_uv": "2f", "in_col": "3f"}
            content = [(g.vbos[n], fmts[n], n) for n in names]
            g.vaos[key] = self.ctx.vertex_array(prog, content, g.ibo, index_element_size=g.index_size)
        return g.vaos[key]

    def _fbo(self, width: int, height: int, with_color: bool, with_normal: bool):
        key = (width, height, with_color, with_normal)
        fb = self._fbos.get(key)
        if fb is not None:
            self._fbos.move_to_end(key)
            return fb
        ctx = self.ctx
        size = (width, height)
        atts = {"geom": ctx.texture(size, 2, dtype="f4")}
        order = ["geom"]
        if with_color:
            atts["color"] = ctx.texture(size, 4, dtype="f1")
            order.append("color")
        if with_normal:
            atts["normal"] = ctx.texture(size, 4, dtype="f4")
            order.append("normal")
        depth = ctx.depth_renderbuffer(size)
        fbo = ctx.framebuffer(color_attachments=[atts[n] for n in order], depth_attachment=depth)
        fb = {"fbo": fbo, "atts": atts, "index": {n: i for i, n in enumerate(order)}, "depth": depth}
        self._fbos[key] = fb
        while len(self._fbos) > self._max_fbos:
            _, old = self._fbos.popitem(last=False)
            _release_fbo(old)
        return fb

    # ------------------------------------------------------------------ rendering
    def render(self, K: np.ndarray, width: int, height: int,
               items: Sequence[tuple[Hashable, np.ndarray]],
               outputs: Collection[str] = ("depth", "instance"),
               znear_mm: float = 10.0, zfar_mm: float = 20000.0,
               scales: Sequence[float] | None = None, shade: float = 0.0) -> RenderOutput:
        """Render ``items`` = [(mesh key, T_m2c 4x4 mm), ...] with one z-buffer (mutual occlusion).

        ``outputs`` any of "depth", "instance", "normal", "color", "mask_all" (per-item unoccluded silhouettes
        and depths, rendered one item at a time), "back_depth" (nearest back faces, a second pass).  ``scales``: per-item uniform scale about the model origin.
        ``shade`` in [0, 1]: 0 = unlit albedo colour, >0 mixes in a headlight Lambert term.
        """
        if self._pid != os.getpid():
            raise YcbvssError("render: this Renderer was created in another process (fork); GL objects do not "
                              "survive a fork -- create the Renderer inside the worker", where="ycbvss.render")
        K, width, height, outs = self._checked_request(K, width, height, outputs, znear_mm, zfar_mm)
        items = list(items)
        mvs, rots, scales = self._model_views(items, scales)
        P = projection_from_K(K, width, height, znear_mm, zfar_mm)
        visible = [k for k in range(len(items)) if self._in_frustum(P, items[k][0], mvs[k], scales[k])]
        # never cull back faces of an item whose bounding sphere contains the camera (we may be inside it)
        self._nocull = {k for k in visible if self._camera_near(items[k][0], mvs[k], scales[k], znear_mm)}
        out = RenderOutput()
        want_main = outs & {"depth", "instance", "normal", "color"}
        if want_main:
            res = self._draw(P, width, height, items, mvs, rots, visible,
                             with_color="color" in outs, with_normal="normal" in outs, shade=shade,
                             read=want_main)
            out.depth_mm, out.instance = res.get("depth"), res.get("instance")
            out.normal_cam, out.color = res.get("normal"), res.get("color")
        if "back_depth" in outs:
            res = self._draw(P, width, height, items, mvs, rots, visible, with_color=False, with_normal=False,
                             shade=0.0, read={"depth", "instance"}, cull_front=True)
            out.back_depth_mm, out.back_instance = res["depth"], res["instance"]
        if "mask_all" in outs:
            out.masks_all, out.depth_all_mm = [], []
            for k in range(len(items)):
                if k not in visible:
                    out.masks_all.append(np.zeros((height, width), dtype=bool))
                    out.depth_all_mm.append(np.zeros((height, width), dtype=np.float32))
                    continue
                res = self._draw(P, width, height, items, mvs, rots, [k], with_color=False, with_normal=False,
                                 shade=0.0, read={"depth"})
                d = res["depth"]
                out.masks_all.append(d > 0)
                out.depth_all_mm.append(d)
        return out

    def _checked_request(self, K, width, height, outputs, znear_mm: float, zfar_mm: float) -> tuple:
        """(K (3, 3), width, height, set of outputs) of a render call, checked."""
        K = check_K(K, where="ycbvss.render")
        if isinstance(outputs, str):
            outputs = (outputs,)
        width, height = int(width), int(height)
        max_vp = self._max_viewport
        if not (0 < width <= max_vp and 0 < height <= max_vp):
            raise YcbvssError(f"render: image size {width}x{height} out of range (1..{max_vp})",
                              where="ycbvss.render")
        outs = set(outputs)
        bad = outs - set(OUTPUTS)
        if bad:
            raise YcbvssError(f"render: unknown outputs {sorted(bad)}; choose from {OUTPUTS}", where="ycbvss.render")
        if not (0 < znear_mm < zfar_mm) or not np.isfinite(zfar_mm):
            raise YcbvssError(f"render: need 0 < znear_mm < zfar_mm, got {znear_mm}, {zfar_mm}",
                              where="ycbvss.render")
        return K, width, height, outs

    def _model_views(self, items: list, scales) -> tuple[list, list, list]:
        """Per item the model-view matrix (4x4, rotation scaled by the item's scale, mm), the rotation
        (3, 3) and the scale; checks keys, poses (4x4 or 3x4, finite) and scales (> 0)."""
        if scales is None:
            scales = [1.0] * len(items)
        scales = [float(s) for s in scales]
        if len(scales) != len(items):
            raise YcbvssError(f"render: {len(scales)} scales for {len(items)} items", where="ycbvss.render")
        mvs, rots = [], []
        for k, ((key, T), s) in enumerate(zip(items, scales)):
            if key not in self._meshes:
                raise YcbvssError(f"render: item {k} uses mesh key {key!r} which was not added "
                                  f"(known: {list(self._meshes)[:10]})", where="ycbvss.render")
            T = np.asarray(T, dtype=np.float64)
            if T.shape == (3, 4):
                T = np.vstack([T, [0, 0, 0, 1]])
            if T.shape != (4, 4) or not np.all(np.isfinite(T)):
                raise YcbvssError(f"render: item {k} ({key!r}) pose must be a finite 4x4 matrix, got shape "
                                  f"{T.shape}", where="ycbvss.render")
            if not (np.isfinite(s) and s > 0):
                raise YcbvssError(f"render: item {k} ({key!r}) scale must be > 0, got {s}", where="ycbvss.render")
            mv = T.copy()
            mv[:3, :3] = T[:3, :3] * s
            mvs.append(mv)
            rots.append(T[:3, :3])
        return mvs, rots, scales

    def _in_frustum(self, P: np.ndarray, key: Hashable, mv: np.ndarray, scale: float) -> bool:
        """False if the item's bounding sphere is entirely outside one of the six clip planes (skip it)."""
        g = self._meshes[key]
        if g.n_faces == 0:
            return False
        c = np.append(mv[:3, :3] @ g.centre + mv[:3, 3], 1.0)
        rad = g.radius * scale
        for plane in (P[3] + P[0], P[3] - P[0], P[3] + P[1], P[3] - P[1], P[3] + P[2], P[3] - P[2]):
            if plane @ c < -rad * np.linalg.norm(plane[:3]):
                return False
        return True

    def _camera_near(self, key: Hashable, mv: np.ndarray, scale: float, znear_mm: float) -> bool:
        g = self._meshes[key]
        return float(np.linalg.norm(mv[:3, :3] @ g.centre + mv[:3, 3])) < g.radius * scale + znear_mm

    def _draw(self, P, width, height, items, mvs, rots, which, with_color, with_normal, shade, read,
              cull_front: bool = False) -> dict:
        """Draw the items ``which`` into a cleared framebuffer of ``width`` x ``height`` and read back the
        outputs named in ``read`` (depth (H, W) float32 mm, instance (H, W) int32, colour (H, W, 3)
        uint8, normal (H, W, 3) float32). ``cull_front``: draw back faces only (every mesh)."""
        ctx = self.ctx
        fb = self._fbo(width, height, with_color, with_normal)
        fbo = fb["fbo"]
        fbo.use()
        fbo.viewport = (0, 0, width, height)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(moderngl.BLEND)
        ctx.cull_face = "front" if cull_front else "back"
        culling, front = None, None

        prog = self._program(with_color, with_normal)
        gl = gil_free_gl()
        prog["u_proj"].write(P.T.astype("f4").tobytes())
        if with_color:
            prog["u_tex"].value = 0
            if prog.get("u_shade", None) is not None:
                prog["u_shade"].value = float(np.clip(shade, 0.0, 1.0))
        for k in which:
            g = self._meshes[items[k][0]]
            if g.n_faces == 0:
                continue
            prog["u_mv"].write(mvs[k].T.astype("f4").tobytes())
            prog["u_inst"].value = float(k + 1)
            if with_normal:
                prog["u_rot"].write(rots[k].T.astype("f4").tobytes())
            if with_color:
                (g.texture or self._white_texture()).use(location=0)
            mirrored = bool(np.linalg.det(mvs[k][:3, :3]) < 0)   # reflection in T: winding flips
            if mirrored != front:
                ctx.front_face = ("ccw" if FRONT_FACE == "cw" else "cw") if mirrored else FRONT_FACE
                front = mirrored
            cull = g.cull if self.cull_back_faces == "auto" else self.cull_back_faces
            if k in self._nocull:
                cull = False
            if cull_front:
                cull = True
            if cull != culling:
                (ctx.enable if cull else ctx.disable)(moderngl.CULL_FACE)
                culling = cull
            vao = self._vao(g, with_color, with_normal)
            isize = getattr(vao, "index_element_size", None) if getattr(vao, "index_buffer", None) is not None else None
            if gl.ok and isize in gl.INDEX_TYPE:     # the same GL calls, the GIL released
                gl.draw_indexed(prog.glo, vao.glo, vao.vertices, isize)
            else:
                vao.render(moderngl.TRIANGLES)
        return _read_outputs(fb, height, width, read)


def _read_outputs(fb: dict, H: int, W: int, read) -> dict:
    """Read the framebuffer ``fb``'s attachments named in ``read`` into numpy images (H, W[, C])."""
    fbo = fb["fbo"]
    gl = gil_free_gl()

    def read_into(out: np.ndarray, components: int, attachment: int, dtype: str) -> None:
        if gl.ok:         # the same read, the GIL released while llvmpipe finishes and converts
            gl.read_into(fbo.glo, out, attachment, components, dtype)
        else:
            fbo.read_into(out, components=components, attachment=attachment, dtype=dtype, alignment=1)

    res = {}
    gi = fb["index"]["geom"]
    if read & {"depth", "instance"} == {"depth"}:
        depth = np.empty((H, W), dtype=np.float32)
        read_into(depth, 1, gi, "f4")
        res["depth"] = depth
    elif read & {"depth", "instance"}:
        geom = fb.setdefault("geom_buf", np.empty((H, W, 2), dtype=np.float32))  # reused staging buffer
        read_into(geom, 2, gi, "f4")
        if "depth" in read:
            res["depth"] = np.ascontiguousarray(geom[..., 0])
        inst = np.empty((H, W), dtype=np.int32)
        np.copyto(inst, geom[..., 1], casting="unsafe")
        res["instance"] = inst
    if "color" in read:
        col = np.empty((H, W, 3), dtype=np.uint8)
        read_into(col, 3, fb["index"]["color"], "f1")
        res["color"] = col
    if "normal" in read:
        nrm = np.empty((H, W, 3), dtype=np.float32)  # unit length from the shader, 0 on background
        read_into(nrm, 3, fb["index"]["normal"], "f4")
        res["normal"] = nrm
    return res


def _release_fbo(fb: dict) -> None:
    fb["fbo"].release()
    for t in fb["atts"].values():
        t.release()
    fb["depth"].release()
