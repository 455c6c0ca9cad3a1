# Headless test of the Blender add-on (blender/gpisvdb_blender.py), registered with CTest when Blender is found:
#   blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_addon.py -- GPISVDB ADDON OUTDIR
# Blender's user scripts folder must point into the build tree (BLENDER_USER_SCRIPTS, set by CTest), so that
# installing the add-on touches nothing of the user's.
import os
import shutil
import subprocess
import sys
import time

import bpy

gpisvdb_exe, addon_file, out_dir = sys.argv[sys.argv.index("--") + 1:]
shutil.rmtree(out_dir, ignore_errors=True)
os.makedirs(out_dir)
checks = 0


def check(condition, message):
    global checks
    checks += 1
    if not condition:
        raise AssertionError(message)


# === The add-on installs with Blender's own installer and enables
bpy.ops.preferences.addon_install(filepath=addon_file, overwrite=True)
bpy.ops.preferences.addon_enable(module="gpisvdb_blender")
import gpisvdb_blender  # noqa: E402  (importable once installed)

bpy.context.preferences.addons["gpisvdb_blender"].preferences.executable = gpisvdb_exe
check(hasattr(bpy.ops.object, "gpisvdb_from_mesh"), "the operator is registered")

# === A small mesh, moved away from the origin so that world space matters
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.0, location=(3.0, 0.0, 0.0))
sphere = bpy.context.active_object
bpy.context.scene.cursor.location = (4.0, 0.0, 0.0)  # on the sphere: the Green source

# === Green's function from the 3D cursor: a Volume with mu, T_diag and green, and the mean surface
result = bpy.ops.object.gpisvdb_from_mesh(task="GREEN", sigma=0.25, voxel_size=0.1, output_dir=out_dir)
check(result == {"FINISHED"}, f"the operator finished: {result}")
volumes = [o for o in bpy.data.objects if o.type == "VOLUME"]
check(len(volumes) == 1, f"one Volume object, got {len(volumes)}")
volume = volumes[0].data
check(volume.grids.load(), "Blender reads the .vdb")
grids = {g.name: g.data_type for g in volume.grids}
check(grids.get("mu") == "FLOAT", f"'mu' is a FLOAT grid: {grids}")
check(grids.get("T_diag") == "VECTOR_FLOAT", f"'T_diag' is a VECTOR_FLOAT grid: {grids}")
check(grids.get("green") == "FLOAT", f"'green' is a FLOAT grid: {grids}")
material = volumes[0].data.materials[0]
attributes = {n.attribute_name for n in material.node_tree.nodes if n.type == "ATTRIBUTE"}
check(attributes == {"mu", "green"}, f"the material reads mu (density) and green (colour): {attributes}")

check(grids.get("density") == "FLOAT", f"'density' (the occupancy) is a FLOAT grid: {grids}")
vdb_path = bpy.path.abspath(volume.filepath)


def render_alpha(vdb_file, tag):
    """Mean alpha of a 24 x 24 Cycles render of `vdb_file` imported as is: no material, no node set-up."""
    scene = bpy.data.scenes.new(f"fog {tag}")
    bpy.ops.object.volume_import(filepath=vdb_file, files=[{"name": os.path.basename(vdb_file)}],
                                 directory=os.path.dirname(vdb_file), align="WORLD", location=(0.0, 0.0, 0.0))
    imported = bpy.context.active_object
    for collection in imported.users_collection:
        collection.objects.unlink(imported)
    scene.collection.objects.link(imported)
    camera = bpy.data.objects.new(f"camera {tag}", bpy.data.cameras.new(f"camera {tag}"))
    camera.location = (3.0, -6.0, 0.0)  # looking along +y at the sphere about (3, 0, 0)
    camera.rotation_euler = (1.5707963, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False  # Debian's Blender is built without OpenImageDenoise
    for layer in scene.view_layers:
        layer.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.render.resolution_x = scene.render.resolution_y = 24
    scene.render.resolution_percentage = 100
    scene.render.filepath = os.path.join(out_dir, f"fog_{tag}.png")
    bpy.ops.render.render(write_still=True, scene=scene.name)
    image = bpy.data.images.load(scene.render.filepath)
    alpha = list(image.pixels)[3::4]
    return sum(alpha) / len(alpha)


# === The occupancy renders as a volume's density with no set-up: Blender's default volume material reads the grid
# called "density". Without it (--fog-name ""), the same import renders nothing.
bare = os.path.join(out_dir, "no_density.vdb")
status = subprocess.run([gpisvdb_exe, "band", os.path.join(out_dir, [f for f in os.listdir(out_dir)
                                                                     if f.endswith("_green_input.obj")][0]),
                         "-o", bare, "--sigma", "0.25", "--voxel-size", "0.1", "--fog-name", "", "--quiet"])
check(status.returncode == 0, "a band without the occupancy grid is written")
with_fog, without_fog = render_alpha(vdb_path, "density"), render_alpha(bare, "none")
check(with_fog > 0.05, f"the occupancy renders: mean alpha {with_fog:.3f}")
check(without_fog < 0.01, f"without a density grid nothing renders: mean alpha {without_fog:.3f}")

surfaces = [o for o in bpy.data.objects if o.type == "MESH" and o.name.endswith("mean surface")]
check(len(surfaces) == 1, "one mean-surface mesh")
mesh = surfaces[0].data
check(len(mesh.vertices) > 100 and len(mesh.polygons) > 100, "the mean surface has vertices and triangles")
for name in ("mu", "green", "stddev"):
    check(name in mesh.attributes and mesh.attributes[name].data_type == "FLOAT", f"point attribute {name}")
mu = [d.value for d in mesh.attributes["mu"].data]
check(min(mu) > 0, "mu is positive on the mean surface")
# World space: the mean surface is a sphere about (3, 0, 0) (radius a little off 1: noise and smoothing), not about
# the origin.
n = len(mesh.vertices)
centre = [sum(v.co[k] for v in mesh.vertices) / n for k in range(3)]
check(abs(centre[0] - 3.0) < 0.05 and abs(centre[1]) < 0.05 and abs(centre[2]) < 0.05, f"centre {centre}")
radii = [((v.co.x - 3.0) ** 2 + v.co.y ** 2 + v.co.z ** 2) ** 0.5 for v in mesh.vertices]
check(0.75 < min(radii) and max(radii) < 1.25, f"mean surface radius {min(radii):.3f}..{max(radii):.3f}")
green = [d.value for d in mesh.attributes["green"].data]
near = min(range(len(green)), key=lambda i: (mesh.vertices[i].co - bpy.context.scene.cursor.location).length)
far = max(range(len(green)), key=lambda i: (mesh.vertices[i].co - bpy.context.scene.cursor.location).length)
check(green[near] > green[far], "the Green's function is largest at the source")

# === Bad input: a mesh without faces is refused with one clear message, and nothing is added
bpy.ops.object.select_all(action="DESELECT")
points = bpy.data.meshes.new("points")
points.from_pydata([(0, 0, 0), (1, 0, 0)], [], [])
lone = bpy.data.objects.new("points", points)
bpy.context.collection.objects.link(lone)
bpy.context.view_layer.objects.active = lone
objects_before = len(bpy.data.objects)
try:
    bpy.ops.object.gpisvdb_from_mesh(task="BAND", output_dir=out_dir)
    check(False, "a mesh without faces is refused")
except RuntimeError as e:
    check("has no faces" in str(e), f"the refusal says why: {e}")
check(len(bpy.data.objects) == objects_before, "nothing is added after a refusal")

# === An error of gpisvdb itself reaches the user with gpisvdb's message
bpy.context.view_layer.objects.active = sphere
try:
    bpy.ops.object.gpisvdb_from_mesh(task="BAND", voxel_size=1e-6, output_dir=out_dir)
    check(False, "an absurd voxel size is refused")
except RuntimeError as e:
    check("voxel" in str(e), f"gpisvdb's message is shown: {e}")

# === Cancelling (Esc) stops gpisvdb at once and leaves no file
vdb = os.path.join(out_dir, "cancelled.vdb")
inputs = [f for f in os.listdir(out_dir) if f.endswith("_green_input.obj")]
check(len(inputs) == 1, f"the world-space triangles were written: {inputs}")
job = gpisvdb_blender.Job([[gpisvdb_exe, "band", os.path.join(out_dir, inputs[0]), "-o", vdb,
                            "--voxel-size", "0.01"]])
job.poll()
time.sleep(1.0)
check(job.poll() is None, "the fine band is still running after 1 s")
start = time.monotonic()
job.cancel()
check(time.monotonic() - start < 5, "cancel returns within 5 s")
check(not os.path.exists(vdb), "no .vdb is left behind")
check(not [f for f in os.listdir(out_dir) if "cancelled" in f], "no temporary is left behind")

print(f"blender add-on test: {checks} checks passed")
