"""A Blender (bpy 5.0) Cycles-CPU scene kept alive across frames: meshes are built once, each frame
only moves objects, sets the camera from K, and renders colour (linear, alpha), z-depth and object index.

Runs ONLY inside a worker process (``python -m ycbvss.blender_scripts.worker``), never in the
process that calls :func:`ycbvss.synth.blender.render_job`.

World = OpenCV camera frame (metres): the camera sits at the origin with ``diag(1,-1,-1)`` and
each object's matrix is ``T_m2c`` (mm -> m) times its uniform scale, so no pose inversion is needed.
fy != fx is realised by scaling the world along y (see :func:`blender_camera_params`); that scale lives on
a parent empty (``diag(1, fy/fx, 1)``) of every object, because ``diag(1, fy/fx, 1) @ R`` is a sheared
matrix that an object's own loc/rot/scale cannot hold: assigning it to ``matrix_world`` silently dropped the
shear (up to 2.4e-4 relative error, i.e. textures and silhouettes off by up to ~0.04 % along y).
"""
from __future__ import annotations

import os
import tempfile
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import OpenEXR
import trimesh

from ycbvss.io.mesh import _texture_reference, load_mesh_mm, mesh_texture_rgb, mesh_uv

from .camera import CV_TO_BLENDER_CAM, blender_camera_params, border_from_bbox, projected_bbox

DEFAULT_LIGHTS = [
    # direction the light travels, in the OpenCV camera frame: from above and slightly behind/left of a camera
    # looking down at a table (like room lighting), so top faces are brighter than front faces
    {"type": "SUN", "direction_cam": [0.25, 1.0, 0.6], "strength": 3.5, "angle_deg": 25.0},
]
DEFAULT_WORLD_STRENGTH = 0.7
GREY = (0.6, 0.6, 0.6)


def _bpy():
    import bpy  # lazy: only inside the Blender worker
    return bpy


class BlenderSession:
    """One Cycles scene. ``configure`` (render settings), ``set_meshes`` (mesh set), ``render``."""

    def __init__(self):
        bpy = _bpy()
        bpy.ops.wm.read_factory_settings(use_empty=True)
        self.bpy = bpy
        self.scene = bpy.context.scene
        # inside the scratch folder of the parent's BlenderWorker (removed when it closes the worker)
        self._tmpdir = Path(tempfile.mkdtemp(prefix="ycbvss-blender-", dir=os.environ.get("YCBVSS_BLENDER_TMP")))
        self._mesh_specs: dict[str, tuple] = {}
        self._mesh_data: dict[str, object] = {}
        self._corners_mm: dict[str, np.ndarray] = {}
        self._pool: dict[str, list] = {}
        self._settings_key = None
        self._material_kind = "principled"
        self._lights = []
        self.warnings: list[str] = []
        cam = bpy.data.cameras.new("cam")
        self.cam_obj = bpy.data.objects.new("cam", cam)
        self.scene.collection.objects.link(self.cam_obj)
        self.scene.camera = self.cam_obj
        self.cam_obj.matrix_world = _matrix(CV_TO_BLENDER_CAM)
        # parent of every rendered object: carries the world y scale fy/fx (see the module docstring)
        self.y_scale_obj = bpy.data.objects.new("world_y_scale", None)
        self.scene.collection.objects.link(self.y_scale_obj)
        cam.sensor_fit = "HORIZONTAL"
        cam.clip_start = 0.01
        cam.clip_end = 100.0
        self.world = bpy.data.worlds.new("world")
        self.scene.world = self.world
        self._setup_render()

    # ------------------------------------------------------------------ settings
    def _setup_render(self):
        sc = self.scene
        r = sc.render
        r.engine = "CYCLES"
        sc.cycles.device = "CPU"
        r.resolution_percentage = 100
        r.film_transparent = True
        r.use_persistent_data = True
        r.use_border = False
        r.use_crop_to_border = False
        sc.cycles.use_auto_tile = False
        sc.cycles.use_adaptive_sampling = True
        sc.cycles.adaptive_threshold = 0.02
        sc.cycles.max_bounces = 3
        sc.cycles.diffuse_bounces = 2
        sc.cycles.glossy_bounces = 1
        sc.cycles.transmission_bounces = 0
        sc.cycles.transparent_max_bounces = 2
        sc.cycles.volume_bounces = 0
        sc.cycles.caustics_reflective = False
        sc.cycles.caustics_refractive = False
        sc.cycles.sample_clamp_indirect = 5.0
        sc.cycles.filter_width = 1.0         # narrow pixel filter: crisp, anti-aliased edges
        sc.view_settings.view_transform = "Standard"
        sc.view_settings.look = "None"
        vl = sc.view_layers[0]
        vl.use_pass_combined = True
        vl.use_pass_z = True
        vl.use_pass_object_index = True
        im = r.image_settings
        im.media_type = "MULTI_LAYER_IMAGE"
        im.file_format = "OPEN_EXR_MULTILAYER"
        im.color_depth = "32"
        im.exr_codec = "ZIP"
        r.filepath = str(self._tmpdir / "render.exr")

    def configure(self, width: int = 640, height: int = 480, samples: int = 16, denoise: bool = True,
                  threads: int = 0, lights: list | None = None, world_strength: float | None = None,
                  max_bounces: int = 3, material: str = "principled", filter_width: float = 1.0,
                  **_ignored) -> None:
        """Render settings. ``material``: "principled" (the lit, glossy default) or "emission" (the
        texture emitted as is: no lighting, a diagnostic of the image formation alone).
        ``filter_width``: Cycles' pixel filter (px; 0.01 samples the pixel centres only)."""
        sc = self.scene
        if material not in ("principled", "emission"):
            raise ValueError(f"unknown material {material!r}")
        if material != self._material_kind:
            self._material_kind = material
            self._mesh_specs.clear()          # rebuilt with the new material by the next set_meshes
        sc.cycles.filter_width = float(filter_width)
        sc.cycles.max_bounces = int(max_bounces)
        sc.cycles.diffuse_bounces = min(2, int(max_bounces))
        sc.cycles.glossy_bounces = min(1, int(max_bounces))
        sc.render.resolution_x = int(width)
        sc.render.resolution_y = int(height)
        sc.cycles.samples = int(samples)
        sc.cycles.use_adaptive_sampling = int(samples) >= 16   # no gain at a handful of samples
        sc.cycles.use_denoising = bool(denoise)
        if denoise:
            sc.cycles.denoiser = "OPENIMAGEDENOISE"
            sc.cycles.denoising_input_passes = "RGB_ALBEDO_NORMAL"
            sc.cycles.denoising_prefilter = "ACCURATE"
        if threads and threads > 0:
            sc.render.threads_mode = "FIXED"
            sc.render.threads = int(threads)
        else:
            sc.render.threads_mode = "AUTO"
        key = (repr(lights), world_strength)
        if key != self._settings_key:
            self._set_lights(DEFAULT_LIGHTS if lights is None else lights,
                             DEFAULT_WORLD_STRENGTH if world_strength is None else float(world_strength))
            self._settings_key = key

    def _set_lights(self, lights: list, world_strength: float) -> None:
        bpy = self.bpy
        for ob in self._lights:
            data = ob.data
            bpy.data.objects.remove(ob)
            bpy.data.lights.remove(data)
        self._lights = []
        self.world.use_nodes = True if hasattr(self.world, "use_nodes") else None
        nt = self.world.node_tree
        bg = next((n for n in nt.nodes if n.type == "BACKGROUND"), None)
        if bg is None:
            bg = nt.nodes.new("ShaderNodeBackground")
            out = next((n for n in nt.nodes if n.type == "OUTPUT_WORLD"), None) or \
                nt.nodes.new("ShaderNodeOutputWorld")
            nt.links.new(bg.outputs[0], out.inputs[0])
        bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bg.inputs["Strength"].default_value = world_strength
        for i, spec in enumerate(lights):
            typ = spec.get("type", "SUN").upper()
            ld = bpy.data.lights.new(f"light{i}", typ)
            ld.energy = float(spec.get("strength", spec.get("energy", 2.5)))
            if typ == "SUN":
                ld.angle = np.deg2rad(float(spec.get("angle_deg", 20.0)))
            elif typ == "AREA":
                ld.size = float(spec.get("size_m", 0.5))
            ob = bpy.data.objects.new(f"light{i}", ld)
            self.scene.collection.objects.link(ob)
            # light local -Z = travel direction; build an orthonormal frame in the world (= camera) frame
            d = np.asarray(spec.get("direction_cam", [0.0, 0.0, 1.0]), np.float64)
            d = d / np.linalg.norm(d)
            z = -d
            a = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
            x = np.cross(a, z); x /= np.linalg.norm(x)
            y = np.cross(z, x)
            M = np.eye(4)
            M[:3, 0], M[:3, 1], M[:3, 2] = x, y, z
            M[:3, 3] = np.asarray(spec.get("position_m", [0.0, 0.0, 0.0]), np.float64)
            ob.matrix_world = _matrix(M)
            self._lights.append(ob)

    # ------------------------------------------------------------------ meshes
    def set_meshes(self, meshes: dict) -> None:
        """Build (or keep) the meshes ``{key: {"path", "unit_scale"?, "scale"?}}``."""
        for key, spec in meshes.items():
            path = str(spec["path"])
            ident = (path, float(spec.get("unit_scale", 1.0)), _mtime(path))
            if self._mesh_specs.get(key) == ident:
                continue
            self._build_mesh(key, path, float(spec.get("unit_scale", 1.0)))
            self._mesh_specs[key] = ident

    def _build_mesh(self, key: str, path: str, unit_scale: float) -> None:
        bpy = self.bpy
        tex_file = _texture_reference(Path(path))
        tex = None
        if tex_file is not None and tex_file.is_file() and tex_file.suffix.lower() in (".png", ".jpg", ".jpeg"):
            # geometry + UVs only; Blender reads the texture file itself (no decode/re-encode here)
            tm = trimesh.load(str(path), process=False, force="mesh", skip_materials=True)
            tm.vertices = np.asarray(tm.vertices, np.float64) * unit_scale
            uv = mesh_uv(tm)
            if uv is not None:
                tex = str(tex_file)
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                tm = load_mesh_mm(path, unit_scale)
            self.warnings.extend(str(w.message) for w in caught)
            uv = mesh_uv(tm)
            tex = mesh_texture_rgb(tm) if uv is not None else None
        v_m = np.asarray(tm.vertices, np.float64) * 1e-3
        f = np.asarray(tm.faces, np.int64)
        self._corners_mm[key] = _bbox_corners(np.asarray(tm.vertices, np.float64))
        me = bpy.data.meshes.new(f"mesh_{key}")
        me.vertices.add(len(v_m))
        me.vertices.foreach_set("co", v_m.astype(np.float32).ravel())
        me.loops.add(f.size)
        me.loops.foreach_set("vertex_index", f.astype(np.int32).ravel())
        me.polygons.add(len(f))
        me.polygons.foreach_set("loop_start", np.arange(0, f.size, 3, dtype=np.int32))
        if uv is not None and tex is not None:
            layer = me.uv_layers.new(name="UVMap")
            layer.data.foreach_set("uv", uv[f.ravel()].astype(np.float32).ravel())
        vcol = None
        if tex is None:
            vc = getattr(getattr(tm, "visual", None), "vertex_colors", None)
            if vc is not None and len(vc) == len(v_m) and getattr(tm.visual, "kind", None) == "vertex":
                vcol = np.asarray(vc, np.float32)[:, :4] / 255.0
                attr = me.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
                attr.data.foreach_set("color", _srgb_to_linear(vcol).ravel())
        me.polygons.foreach_set("use_smooth", np.ones(len(f), dtype=bool))
        me.update()
        me.materials.append(self._material(key, tex, vcol is not None))
        old = self._mesh_data.get(key)
        for ob in self._pool.get(key, []):
            ob.data = me
        if old is not None:
            bpy.data.meshes.remove(old)
        self._mesh_data[key] = me

    def _material(self, key: str, tex_rgb, has_vcol: bool):
        bpy = self.bpy
        mat = bpy.data.materials.new(f"mat_{key}")
        if hasattr(mat, "use_nodes"):
            try:
                mat.use_nodes = True
            except Exception:  # deprecated / always on in Blender 5
                pass
        nt = mat.node_tree
        bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
        if self._material_kind == "emission":
            em = nt.nodes.new("ShaderNodeEmission")
            em.inputs["Strength"].default_value = 1.0
            out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
            nt.links.new(em.outputs[0], out.inputs["Surface"])
            bsdf, colour_in = em, "Color"      # the colour below goes to the emission
        else:
            colour_in = "Base Color"
            bsdf.inputs["Roughness"].default_value = 0.55
            bsdf.inputs["Specular IOR Level"].default_value = 0.35
        if tex_rgb is not None:
            if isinstance(tex_rgb, str):           # a texture file Blender can read directly
                tex_path = Path(tex_rgb)
            else:
                tex_path = self._tmpdir / f"tex_{key}.png"
                cv2.imwrite(str(tex_path), np.ascontiguousarray(tex_rgb[..., ::-1]), [cv2.IMWRITE_PNG_COMPRESSION, 1])
            img = bpy.data.images.load(str(tex_path), check_existing=False)
            img.colorspace_settings.name = "sRGB"
            node = nt.nodes.new("ShaderNodeTexImage")
            node.image = img
            node.interpolation = "Linear"
            nt.links.new(node.outputs["Color"], bsdf.inputs[colour_in])
        elif has_vcol:
            node = nt.nodes.new("ShaderNodeVertexColor")
            node.layer_name = "Col"
            nt.links.new(node.outputs["Color"], bsdf.inputs[colour_in])
        else:
            g = _srgb_to_linear(np.array(GREY, np.float32))
            bsdf.inputs[colour_in].default_value = (float(g[0]), float(g[1]), float(g[2]), 1.0)
        return mat

    def _object(self, key: str, k: int):
        pool = self._pool.setdefault(key, [])
        while len(pool) <= k:
            ob = self.bpy.data.objects.new(f"{key}.{len(pool)}", self._mesh_data[key])
            self.scene.collection.objects.link(ob)
            ob.parent = self.y_scale_obj
            ob.matrix_parent_inverse = _matrix(np.eye(4))
            pool.append(ob)
        return pool[k]

    # ------------------------------------------------------------------ render
    def render(self, frame: dict, meshes: dict, seed: int) -> dict:
        """Render one frame; returns ``{"rgba": (H,W,4) f32 linear premultiplied, "depth_mm": (H,W) f32
        (0 background), "index": (H,W) uint16 pass_index, "render_s"}``."""
        sc = self.scene
        W, H = sc.render.resolution_x, sc.render.resolution_y
        K = np.asarray(frame["K"], np.float64).reshape(3, 3)
        p = blender_camera_params(K, W, H)
        cam = self.cam_obj.data
        cam.sensor_width = p["sensor_width"]
        cam.lens = p["lens"]
        cam.shift_x = p["shift_x"]
        cam.shift_y = p["shift_y"]
        # fy != fx: scale the world along y -- on the parent, so each object keeps an exact rotation * scale
        self.y_scale_obj.scale = (1.0, p["y_scale"], 1.0)
        sc.cycles.seed = int(seed) % (2 ** 31 - 1)
        used: dict[str, int] = {}
        bbox = None
        for obj in frame["objects"]:
            key = obj["mesh"]
            k = used.get(key, 0)
            used[key] = k + 1
            ob = self._object(key, k)
            s = float(obj.get("scale", meshes.get(key, {}).get("scale", 1.0)))
            T = np.asarray(obj["T_m2c"], np.float64).reshape(4, 4)
            M = np.eye(4)
            M[:3, :3] = T[:3, :3] * s
            M[:3, 3] = T[:3, 3] * 1e-3
            ob.matrix_basis = _matrix(M)     # rotation * uniform scale + translation: exactly representable
            ob.pass_index = int(obj.get("pass_index", 0))
            ob.hide_render = False
            Ts = T.copy()
            Ts[:3, :3] = T[:3, :3] * s
            bb = projected_bbox(K, Ts, self._corners_mm[key])
            if bb is None:
                bbox = (0.0, 0.0, W - 1.0, H - 1.0)   # a corner behind the camera: render all
            elif bbox is None:
                bbox = bb
            else:
                bbox = (min(bbox[0], bb[0]), min(bbox[1], bb[1]), max(bbox[2], bb[2]), max(bbox[3], bb[3]))
        for key, pool in self._pool.items():
            for ob in pool[used.get(key, 0):]:
                ob.hide_render = True
        border = None if (bbox is None or frame.get("full_frame")) else border_from_bbox(bbox, W, H)
        empty = bbox is None or (border is None and not frame.get("full_frame"))
        if empty:
            return {"rgba": np.zeros((H, W, 4), np.float32), "depth_mm": np.zeros((H, W), np.float32),
                    "index": np.zeros((H, W), np.uint16), "render_s": 0.0}
        r = sc.render
        if border is None:
            r.use_border = False
        else:
            r.use_border = True
            r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = border
        t0, c0 = time.perf_counter(), time.process_time()
        self.bpy.ops.render.render(write_still=True)
        out = _read_multilayer(Path(r.filepath))
        out["render_s"] = time.perf_counter() - t0
        out["render_cpu_s"] = time.process_time() - c0
        return out


def _read_multilayer(path: Path) -> dict:
    chans = {}
    with OpenEXR.File(str(path), separate_channels=False) as f:
        for part in f.parts:
            for name, ch in part.channels.items():
                chans[name] = np.array(ch.pixels, copy=True)
    rgba = depth = index = None
    for name, px in chans.items():
        if name.endswith("Combined") or name.endswith("Combined.RGBA"):
            rgba = px.astype(np.float32)
        elif name.endswith("Depth.Z") or name.endswith("Depth"):
            depth = px.astype(np.float32)
        elif "Object Index" in name or "IndexOB" in name:
            index = px if px.ndim == 2 else px[..., 0]
    if rgba is None or depth is None or index is None:
        raise RuntimeError(f"render output lacks passes: {sorted(chans)}")
    alpha = rgba[..., 3]
    idx = np.rint(index).astype(np.uint16)
    fg = (idx > 0) | (alpha > 0)
    depth_mm = np.where(fg & (depth < 1e6) & np.isfinite(depth), depth * 1000.0, 0.0).astype(np.float32)
    return {"rgba": rgba, "depth_mm": depth_mm, "index": idx}


def _matrix(M):
    # lazy: only inside Blender
    import mathutils
    return mathutils.Matrix([list(map(float, row)) for row in np.asarray(M).reshape(4, 4)])


def _mtime(path: str) -> float:
    try:
        return os.path.getmtime(path)
    except OSError:
        return 0.0


def _bbox_corners(v: np.ndarray) -> np.ndarray:
    lo, hi = v.min(0), v.max(0)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def _srgb_to_linear(c):
    c = np.asarray(c, np.float32)
    out = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)
    if out.ndim and out.shape[-1] == 4:
        out[..., 3] = c[..., 3]
    return out
