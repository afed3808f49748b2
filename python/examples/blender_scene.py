"""The Blender recipe as a script: a smokelab VDB sequence imported into a
scene with the README's two colours and the obstacle as a mesh, rendered.

    smokelab export vdb RUN_DIR --up z --out vdb/
    blender -b --factory-startup --python blender_scene.py -- vdb/ --render scene.png

Options after ``--``: ``--frame N`` (default: the last file), ``--size WxH``
(default 640x480), ``--samples N`` (Cycles samples, default 16). Run it
with ``blender`` without ``-b`` to keep the scene open and render it
yourself. The steps, each one function below:

1. ``import_sequence``: *Add → Volume → Import OpenVDB* of every
   ``frame_NNNN.vdb`` (as ``blender_import.py`` does) and the scene's frame
   range set to the files (Blender leaves its end frame at 250).
2. ``two_colour_material`` (runs with gases ``hot`` and ``cold``): the
   README's look, hot red and cold blue — two *Attribute* nodes read the
   grids, a *Combine Color* node makes (hot, 0, cold) the *Principled
   Volume*'s colour, whose density stays the grid ``density``.
3. ``obstacle_mesh`` (runs with obstacles): Blender takes no modifiers on a
   volume object, so a mesh object carries a *Volume to Mesh* modifier that
   reads the volume's level set ``obstacle`` at 0; applied, and moved by
   half a voxel to where OpenVDB puts the surface (Blender 3.4 meshes the
   level set half a voxel off along every axis; the modifier itself
   ignores the mesh object's location, so the move comes after applying).
4. ``render``: an orthographic camera looking along +y (z up), a sun, a
   grey world, Cycles on the CPU.

Prints one line ``REPORT {json}``: the material's kind, the obstacle mesh's
vertex count, world bounds and the heights where a vertical ray down the
middle crosses it, the frame rendered, the image size, the share of
pixels that differ from the background, and the shares of reddish and
bluish pixels.
"""

import json
import sys
from pathlib import Path

import bpy
from mathutils import Vector

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blender_import import bounds, front_camera, import_sequence  # noqa: E402

#: The world's colour; a pixel that differs from it shows smoke or obstacle.
BACKGROUND = (0.05, 0.05, 0.05)


# ANCHOR: frame_range
def frame_range(obj):
    """Play the whole sequence: scene frames 1 … number of files."""
    scene = bpy.context.scene
    scene.frame_start = 1
    scene.frame_end = obj.data.frame_duration
# ANCHOR_END: frame_range


# ANCHOR: two_colour
def two_colour_material(obj):
    """Hot red, cold blue: the Principled Volume's colour is
    (hot, 0, cold) read from the grids, its density the grid ``density``."""
    material = bpy.data.materials.new("smokelab hot/cold")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    volume = nodes.new("ShaderNodeVolumePrincipled")
    volume.inputs["Density Attribute"].default_value = "density"
    volume.inputs["Density"].default_value = 5.0
    combine = nodes.new("ShaderNodeCombineColor")
    for gas, channel in (("hot", "Red"), ("cold", "Blue")):
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_type = "GEOMETRY"
        attribute.attribute_name = gas
        links.new(attribute.outputs["Fac"], combine.inputs[channel])
    links.new(combine.outputs["Color"], volume.inputs["Color"])
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(volume.outputs["Volume"], output.inputs["Volume"])
    obj.data.materials.append(material)
# ANCHOR_END: two_colour


# ANCHOR: obstacle
def obstacle_mesh(obj, voxel):
    """The level set ``obstacle`` at 0 as a mesh object: a *Volume to Mesh*
    modifier on a mesh object reading the volume, applied (the obstacles
    do not move), then the mesh moved back by half a voxel (``voxel``: the
    volume's voxel size along x, y, z in world units)."""
    mesh = bpy.data.objects.new("obstacle", bpy.data.meshes.new("obstacle"))
    bpy.context.scene.collection.objects.link(mesh)
    modifier = mesh.modifiers.new("obstacle", "VOLUME_TO_MESH")
    modifier.object = obj
    modifier.grid_name = "obstacle"
    modifier.threshold = 0.0
    bpy.context.view_layer.objects.active = mesh
    bpy.ops.object.modifier_apply(modifier="obstacle")
    mesh.location = -0.5 * Vector(voxel)
    material = bpy.data.materials.new("obstacle")
    material.diffuse_color = (0.6, 0.6, 0.6, 1.0)
    mesh.data.materials.append(material)
    mesh.visible_shadow = False  # a walled box would leave its inside in the dark
    return mesh
# ANCHOR_END: obstacle


def voxel_size(obj):
    """The volume's voxel size along x, y, z in world units: the scale of
    the ``density`` grid's voxel-to-object matrix (the object is unscaled)."""
    grid = obj.data.grids["density"]
    grid.load()
    return [abs(s) for s in grid.matrix_object.to_scale()]


def surfaces_along(origin, direction, limit=8):
    """The world positions where a ray from ``origin`` along ``direction``
    crosses the scene's meshes, nearest first (at most ``limit``)."""
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    hits, origin, direction = [], Vector(origin), Vector(direction).normalized()
    for _ in range(limit):
        hit, location, *_ = scene.ray_cast(depsgraph, origin, direction)
        if not hit:
            break
        hits.append(location.copy())
        origin = location + 1e-4 * direction
    return hits


def front_wall_cut(camera, low, extent):
    """Clip the camera's view past the obstacle's front wall, if a wall
    spans the view's front (a run in a walled box), so the smoke inside
    shows; the other walls stay as the backdrop."""
    hits = surfaces_along(camera.location, (0.0, 1.0, 0.0), limit=2)
    if len(hits) == 2 and abs(hits[0].y - low[1]) < 0.05 * extent:
        camera.data.clip_start = hits[1].y - camera.location.y + 1e-3 * extent
        camera.data.clip_end = camera.data.clip_start + 3 * extent


def render(path: Path, size, samples):
    """Render the scene from −y towards +y (z up in the image) into
    ``path``; returns the share of pixels that differ from the background
    and the shares of pixels whose red, or blue, exceeds both other
    channels by 0.05 (reddish and bluish pixels)."""
    scene = bpy.context.scene
    objects = [o for o in scene.objects if o.type in ("VOLUME", "MESH")]
    corners = [c for o in objects for c in bounds(o)]
    low = [min(c[a] for c in corners) for a in range(3)]
    high = [max(c[a] for c in corners) for a in range(3)]
    camera, extent = front_camera(low, high, margin=1.15)
    front_wall_cut(camera, low, extent)
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 6.0
    sun.rotation_euler = (0.9, 0.0, 0.4)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("background")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*BACKGROUND, 1.0)
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    pixels = list(image.pixels)
    rgb = [pixels[i:i + 3] for i in range(0, len(pixels), 4)]
    background = [c ** (1 / 2.2) for c in BACKGROUND]  # the saved PNG is sRGB
    shown = [p for p in rgb if max(abs(a - b) for a, b in zip(p, background)) > 0.04]
    tinted = lambda k: sum(all(p[k] > p[j] + 0.05 for j in range(3) if j != k) for p in rgb)  # noqa: E731
    return len(shown) / len(rgb), tinted(0) / len(rgb), tinted(2) / len(rgb)


def main(args):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = import_sequence(Path(args[0]).resolve())
    frame_range(obj)
    frame = int(args[args.index("--frame") + 1]) if "--frame" in args else obj.data.frame_duration
    bpy.context.scene.frame_set(frame)
    volume = obj.data
    volume.grids.load()
    names = {g.name for g in volume.grids}
    report = {"frame": frame, "frames": volume.frame_duration}
    if {"hot", "cold"} <= names:
        two_colour_material(obj)
        report["material"] = "hot/cold"
    else:
        report["material"] = "default"
    if "obstacle" in names:
        mesh = obstacle_mesh(obj, voxel_size(obj))
        report["obstacle_vertices"] = len(mesh.data.vertices)
        report["obstacle_low"], report["obstacle_high"] = bounds(mesh)
        low, high = report["obstacle_low"], report["obstacle_high"]
        above = ((low[0] + high[0]) / 2, (low[1] + high[1]) / 2, high[2] + 1.0)
        report["voxel"] = voxel_size(obj)
        report["obstacle_heights"] = [p.z for p in surfaces_along(above, (0.0, 0.0, -1.0))]
    if "--render" in args:
        size = tuple(int(n) for n in (args[args.index("--size") + 1] if "--size" in args else "640x480").split("x"))
        samples = int(args[args.index("--samples") + 1]) if "--samples" in args else 16
        path = Path(args[args.index("--render") + 1]).resolve()
        report["size"] = list(size)
        report["shown"], report["reddish"], report["bluish"] = render(path, size, samples)
    print("REPORT " + json.dumps(report))


main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
