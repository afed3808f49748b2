"""Import a smokelab VDB sequence into Blender, headless, and report what
Blender sees (a check of the recipe in python/README.md).

    smokelab export vdb RUN_DIR --up z --out vdb/
    blender -b --factory-startup --python blender_import.py -- vdb/ [--render out.png]

Prints one line ``REPORT {json}``: the grids Blender lists, whether it took
the files as a sequence and how many frames, the object's world bounding
box; with ``--render``, a 48×48 Cycles render of frame 1 with the *default*
volume material (the object gets none: Blender's default reads the grid
named ``density``) seen from −y towards +y, z up, and the render's
coverage (pixels with alpha > 0.01) and coverage-weighted height (0 bottom,
1 top of the image).
"""

import json
import sys
from pathlib import Path

import bpy


def import_sequence(folder: Path):
    """Add the folder's ``frame_NNNN.vdb`` files as one volume object, as
    *Add → Volume → Import OpenVDB* with every file selected does."""
    files = sorted(p.name for p in folder.glob("frame_*.vdb"))
    if not files:
        sys.exit(f"error: {folder} holds no frame_NNNN.vdb files")
    bpy.ops.object.volume_import(
        filepath=str(folder / files[0]),
        directory=str(folder) + "/",
        files=[{"name": f} for f in files],
        use_sequence_detection=True,
    )
    return bpy.context.active_object


def render(obj, path: Path):
    """A small Cycles render of ``obj`` with its default material, against
    a transparent background; returns (coverage, height of the coverage)."""
    scene = bpy.context.scene
    front_camera(*bounds(obj), margin=1.2)
    light = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    light.rotation_euler = (1.2, 0.0, 0.3)
    scene.collection.objects.link(light)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
    scene.cycles.device = "CPU"
    scene.render.film_transparent = True
    scene.render.resolution_x = scene.render.resolution_y = 48
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    w, h = image.size
    alpha = list(image.pixels)[3::4]  # rows bottom to top
    covered = [(n // w) / (h - 1) for n, a in enumerate(alpha) if a > 0.01]
    height = sum(covered) / len(covered) if covered else None
    return len(covered) / (w * h), height


def front_camera(low, high, margin):
    """An orthographic scene camera looking along +y (z up in the image)
    at the box ``low``…``high``, its view ``margin`` × the box's largest
    side; returns the camera and that side."""
    scene = bpy.context.scene
    centre = [(a + b) / 2 for a, b in zip(low, high)]
    extent = max(b - a for a, b in zip(low, high))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = margin * extent
    camera.location = (centre[0], low[1] - 2 * extent, centre[2])
    camera.rotation_euler = (1.5707963, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera, extent


def bounds(obj):
    """The evaluated object's world bounding box as (low, high) corners."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    corners = [evaluated.matrix_world @ __import__("mathutils").Vector(c) for c in evaluated.bound_box]
    return [min(c[a] for c in corners) for a in range(3)], [max(c[a] for c in corners) for a in range(3)]


def main(args):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = import_sequence(Path(args[0]).resolve())
    volume = obj.data
    volume.grids.load()
    low, high = bounds(obj)
    report = {
        "grids": [g.name for g in volume.grids],
        "load_error": volume.grids.error_message,
        "is_sequence": volume.is_sequence,
        "frames": volume.frame_duration,
        "materials": [m.name for m in volume.materials if m],
        "bbox_low": low,
        "bbox_high": high,
    }
    if "--render" in args:
        report["coverage"], report["height"] = render(obj, Path(args[args.index("--render") + 1]).resolve())
    print("REPORT " + json.dumps(report))


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
