"""Procedural multi-object scenes built in code (the demo default that needs no download).

``make_scene(seed, n_frames, width, height)`` -> :class:`ProceduralScene` (models with textured
meshes in mm, frames with exact poses on a camera arc); ``render_fast(scene)`` renders it with the
OpenGL renderer (Lambertian shading); ``write_models(scene, dir)`` writes a BOP models folder.
"""
from .io import OBJECTS_META, write_models, write_table
from .render import render_fast, render_frame_fast
from .scene import OBJECT_NAMES, ProceduralScene, make_scene

__all__ = ["make_scene", "ProceduralScene", "OBJECT_NAMES", "render_fast", "render_frame_fast", "write_models",
           "write_table", "OBJECTS_META"]
