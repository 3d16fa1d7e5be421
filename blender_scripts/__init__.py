"""Code that runs inside Blender worker processes (``python -m ycbvss.blender_scripts.worker``).

``session`` (bpy scene, Cycles) and ``worker`` (JSON-lines loop) import bpy and run only in workers;
``camera`` (K -> Blender camera, pure math) and ``outputs`` (EXR/PNG pass files) are bpy-free helpers.
"""
