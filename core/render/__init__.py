"""Fast headless OpenGL rasteriser (moderngl, EGL) for masks, depth, gt_info and the refiner.

``Renderer`` renders lists of (mesh key, T_m2c) with mutual occlusion into exact float32 depth (mm),
instance ids, camera-frame normals and textured colour, for any K and image size (OpenCV pixel centres).
"""
from .context import context_info, get_context
from .projection import FRONT_FACE, clip_to_pixels, projection_from_K, roi_K
from .renderer import OUTPUTS, Renderer, RenderOutput
from .texture import mesh_texture, mesh_vertex_colors, smooth_vertex_normals

__all__ = ["Renderer", "RenderOutput", "OUTPUTS", "mesh_texture", "mesh_vertex_colors", "smooth_vertex_normals",
           "projection_from_K", "clip_to_pixels", "roi_K", "FRONT_FACE", "get_context", "context_info"]
