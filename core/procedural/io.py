"""Write a procedural scene's models as a BOP models folder (PLY in mm + texture PNG + models_info.json)."""
from __future__ import annotations

from pathlib import Path

from ..io.atomic import write_json_atomic
from ..io.mesh import compute_models_info, write_ply_mm
from .scene import ProceduralScene

OBJECTS_META = "ycbvss_objects.json"


def write_models(scene: ProceduralScene, models_dir: str | Path, set_paths: bool = True) -> dict[int, Path]:
    """Write ``obj_XXXXXX.ply`` (+ ``obj_XXXXXX.png`` texture) and ``models_info.json`` under
    ``models_dir``, plus ``ycbvss_objects.json`` (names, textureless flags). With ``set_paths`` the
    scene's ObjectModels then point at the written files. Returns obj_id -> PLY path."""
    models_dir = Path(models_dir)
    paths, info, meta = {}, {}, {}
    for oid, m in sorted(scene.models.items()):
        p = models_dir / f"obj_{oid:06d}.ply"
        write_ply_mm(p, m.mesh, texture_name=f"obj_{oid:06d}.png")
        info[str(oid)] = compute_models_info(m.mesh)
        meta[str(oid)] = {"name": m.name, "textureless": bool(m.textureless)}
        paths[oid] = p
        if set_paths:
            m.path = p
    write_json_atomic(models_dir / "models_info.json", info)
    write_json_atomic(models_dir / OBJECTS_META, meta)
    return paths


def write_table(scene: ProceduralScene, path: str | Path) -> Path:
    """Write the table top as a textured PLY (mm, world frame) with its texture PNG beside it."""
    path = Path(path)
    write_ply_mm(path, scene.table_mesh, texture_name=path.stem + ".png")
    return path
