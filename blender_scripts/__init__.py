"""Scripts executed inside Blender worker processes (bpy); nothing here is imported by the main process."""
