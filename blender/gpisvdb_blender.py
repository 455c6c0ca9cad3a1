# gpisvdb add-on for Blender 3.4+: the GPIS of the selected mesh as a Volume object (density = the surface
# density mu, colour = another grid) and its mean surface as a mesh with the grids as attributes.
#
# Install: Edit > Preferences > Add-ons > Install... > this file; enable "Object: gpisvdb"; set the path of the
# gpisvdb program in the add-on's preferences if it is not on PATH. Use: select a mesh, Object > gpisvdb: GPIS from
# selected mesh (or F3 and type "GPIS"). docs/blender.md.
#
# The add-on runs the gpisvdb program in a subprocess rather than loading a compiled module into Blender: builds
# from blender.org bundle their own Python, which a module compiled for the system's Python cannot be loaded into,
# and a subprocess keeps Blender responsive and cancellable (Esc sends SIGINT; gpisvdb then stops within a second
# and leaves no file).

import math
import os
import queue
import shutil
import signal
import struct
import subprocess
import tempfile
import threading

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

bl_info = {
    "name": "gpisvdb",
    "author": "gpisvdb developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Object > gpisvdb: GPIS from selected mesh",
    "description": "Uncertainty-aware surface density, Green's function and geodesic distance of a noisy mesh, "
                   "as an OpenVDB volume and a coloured mean surface",
    "category": "Object",
}

TASKS = [
    ("BAND", "Surface density", "The band only: mu, mean, stddev, T"),
    ("GREEN", "Green's function", "Green's function of the GPIS Laplacian from the 3D cursor"),
    ("GEODESIC", "Geodesic distance", "Geodesic distance on the GPIS from the 3D cursor"),
]
COLOUR_GRID = {"BAND": "stddev", "GREEN": "green", "GEODESIC": "geodesic"}


class GpisvdbError(RuntimeError):
    pass


# === Finding the program


def _addon_preferences(context):
    addon = context.preferences.addons.get(__name__)
    return addon.preferences if addon else None


def find_executable(context):
    prefs = _addon_preferences(context)
    configured = bpy.path.abspath(prefs.executable) if prefs and prefs.executable else ""
    candidates = [configured, os.environ.get("GPISVDB_EXE", ""), shutil.which("gpisvdb") or ""]
    for path in candidates:
        if path and os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    raise GpisvdbError("the gpisvdb program was not found: set its path in the add-on's preferences "
                       "(Edit > Preferences > Add-ons > gpisvdb), or put it on PATH")


# === Writing the selected mesh (world-space triangles)


def write_world_triangles(obj, depsgraph, path):
    """Writes the evaluated mesh of `obj` (modifiers applied) as world-space triangles in an OBJ file."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        if len(mesh.loop_triangles) == 0:
            raise GpisvdbError(f"'{obj.name}' has no faces: gpisvdb needs a triangle mesh")
        matrix = obj.matrix_world
        with open(path, "w") as out:
            out.write(f"# {obj.name}, world space, from Blender\n")
            for v in mesh.vertices:
                p = matrix @ v.co
                out.write(f"v {p.x:.9g} {p.y:.9g} {p.z:.9g}\n")
            for t in mesh.loop_triangles:
                a, b, c = t.vertices
                out.write(f"f {a + 1} {b + 1} {c + 1}\n")
        return len(mesh.loop_triangles)
    finally:
        evaluated.to_mesh_clear()


# === Reading gpisvdb's mean surface (binary little-endian PLY from `gpisvdb mesh`)

_PLY_TYPES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
              "float": "f", "double": "d", "int8": "b", "uint8": "B", "int32": "i", "float32": "f"}


def read_ply(path):
    """Returns (vertices as [(x, y, z)], triangles as [(a, b, c)], {property name: [values]})."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise GpisvdbError(f"{path}: not a PLY file")
        elements, fmt = [], None
        while True:
            line = f.readline()
            if not line:
                raise GpisvdbError(f"{path}: PLY header has no end_header")
            words = line.decode("ascii", "replace").split()
            if not words:
                continue
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property":
                elements[-1][2].append(words[1:])
            elif words[0] == "end_header":
                break
        if fmt != "binary_little_endian":
            raise GpisvdbError(f"{path}: expected a binary little-endian PLY from gpisvdb mesh, got {fmt}")
        vertices, faces, fields = [], [], {}
        for name, count, props in elements:
            if name == "vertex":
                names = [p[-1] for p in props]
                row = struct.Struct("<" + "".join(_PLY_TYPES[p[0]] for p in props))
                data = f.read(row.size * count)
                columns = list(zip(*row.iter_unpack(data))) if count else [[] for _ in names]
                by_name = dict(zip(names, columns))
                vertices = list(zip(by_name["x"], by_name["y"], by_name["z"]))
                fields = {n: list(c) for n, c in by_name.items() if n not in ("x", "y", "z")}
            elif name == "face":
                count_type, index_type = _PLY_TYPES[props[0][1]], _PLY_TYPES[props[0][2]]
                count_size = struct.calcsize("<" + count_type)
                for _ in range(count):
                    (n,) = struct.unpack("<" + count_type, f.read(count_size))
                    idx = struct.unpack("<" + index_type * n, f.read(struct.calcsize("<" + index_type) * n))
                    for k in range(1, n - 1):  # fan, in case a face is not a triangle
                        faces.append((idx[0], idx[k], idx[k + 1]))
            else:
                raise GpisvdbError(f"{path}: unexpected PLY element '{name}'")
        return vertices, faces, fields


# === Building the Blender objects


def _vector_groups(fields):
    """Splits PLY properties into scalars and 3-vectors (name_x, name_y, name_z)."""
    scalars, vectors = {}, {}
    for name, values in fields.items():
        base, _, axis = name.rpartition("_")
        if axis in ("x", "y", "z") and all(f"{base}_{a}" in fields for a in "xyz"):
            vectors.setdefault(base, {})[axis] = values
        else:
            scalars[name] = values
    return scalars, vectors


def add_mean_surface(context, name, ply_path):
    vertices, faces, fields = read_ply(ply_path)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    scalars, vectors = _vector_groups(fields)
    for field, values in scalars.items():
        attribute = mesh.attributes.new(field, "FLOAT", "POINT")
        attribute.data.foreach_set("value", values)
    for field, axes in vectors.items():
        attribute = mesh.attributes.new(field, "FLOAT_VECTOR", "POINT")
        flat = [c for xyz in zip(axes["x"], axes["y"], axes["z"]) for c in xyz]
        attribute.data.foreach_set("vector", flat)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    context.collection.objects.link(obj)
    return obj, scalars


def volume_material(name, colour_grid, colour_range, density_scale):
    """Principled Volume whose density reads `mu` (times density_scale) and whose colour reads `colour_grid`."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    volume = nodes.new("ShaderNodeVolumePrincipled")
    mu = nodes.new("ShaderNodeAttribute")
    mu.attribute_name = "mu"
    scale = nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = density_scale
    links.new(mu.outputs["Fac"], scale.inputs[0])
    links.new(scale.outputs["Value"], volume.inputs["Density"])
    if colour_grid:
        colour = nodes.new("ShaderNodeAttribute")
        colour.attribute_name = colour_grid
        remap = nodes.new("ShaderNodeMapRange")
        remap.inputs["From Min"].default_value, remap.inputs["From Max"].default_value = colour_range
        ramp = nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].color = (0.05, 0.1, 0.6, 1.0)
        ramp.color_ramp.elements[1].color = (1.0, 0.85, 0.1, 1.0)
        links.new(colour.outputs["Fac"], remap.inputs["Value"])
        links.new(remap.outputs["Result"], ramp.inputs["Fac"])
        links.new(ramp.outputs["Color"], volume.inputs["Color"])
    links.new(volume.outputs["Volume"], output.inputs["Volume"])
    return material


def add_volume(context, name, vdb_path, material):
    volume = bpy.data.volumes.new(name)
    volume.filepath = vdb_path
    if not volume.grids.load():
        raise GpisvdbError(f"Blender could not read {vdb_path}: {volume.grids.error_message}")
    obj = bpy.data.objects.new(name, volume)
    context.collection.objects.link(obj)
    obj.data.materials.append(material)
    return obj


# === Running gpisvdb


class Job:
    """The gpisvdb commands of one run, executed one after the other in a subprocess, with their progress."""

    def __init__(self, commands):
        self.commands = list(commands)
        self.process = None
        self.lines = queue.Queue()
        self.stage, self.percent, self.step = "", 0, 0
        self.errors = []

    def _start_next(self):
        env = dict(os.environ, GPISVDB_PROGRESS="lines")
        self.process = subprocess.Popen(self.commands[self.step], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE, env=env, text=True)
        self.reader = threading.Thread(target=self._read, args=(self.process.stderr,), daemon=True)
        self.reader.start()

    def _read(self, stream):
        for line in stream:
            self.lines.put(line.rstrip("\n"))

    def _drain(self):
        while True:
            try:
                line = self.lines.get_nowait()
            except queue.Empty:
                return
            words = line.split()
            if len(words) == 3 and words[0] == "gpisvdb-progress":
                self.stage, self.percent = words[1], int(words[2])
            elif line:
                self.errors.append(line)

    def poll(self):
        """Advances the job; returns None while running, then True (done) or raises GpisvdbError."""
        if self.process is None:
            self._start_next()
        code = self.process.poll()
        if code is None:
            self._drain()
            return None
        self.reader.join(timeout=5)  # the rest of its stderr, the error message included
        self._drain()
        self.process.stderr.close()
        self.process = None
        if code != 0:
            message = self.errors[-1] if self.errors else f"gpisvdb exited with code {code}"
            raise GpisvdbError(message.removeprefix("gpisvdb: error: "))
        self.step += 1
        self.stage, self.percent = "", 0
        return True if self.step == len(self.commands) else None

    def fraction(self):
        return (self.step + self.percent / 100.0) / len(self.commands)

    def cancel(self):
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)  # gpisvdb stops within a second and removes its outputs
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()

    def run_to_end(self):
        """Blocking (background mode, no event loop): polls until every command has ended."""
        while self.poll() is None:
            if self.process is not None:
                try:
                    self.process.wait(timeout=0.1)
                except subprocess.TimeoutExpired:
                    pass


class GPISVDB_OT_from_mesh(bpy.types.Operator):
    """Run gpisvdb on the selected mesh: the surface density mu as a volume, a field on its mean surface"""

    bl_idname = "object.gpisvdb_from_mesh"
    bl_label = "GPIS from selected mesh"
    bl_options = {"REGISTER", "UNDO"}

    task: EnumProperty(name="Field", items=TASKS, default="BAND")
    sigma: FloatProperty(name="Noise sigma", default=0.5, min=1e-4, soft_max=4.0,
                         description="Noise std of the vertices, relative to the length scale l (gpisvdb --sigma)")
    smoothing: FloatProperty(name="Smoothing", default=0.4, min=1e-4, soft_max=4.0,
                             description="Kernel smoothing s, relative to l (gpisvdb --smoothing)")
    voxel_size: FloatProperty(name="Voxel size", default=0.0, min=0.0, unit="LENGTH",
                              description="Voxel size in world units; 0: gpisvdb's default rule")
    resolution_scale: FloatProperty(name="Resolution scale", default=1.0, min=0.05, max=10.0,
                                    description="Scales the default voxel size (below 1 is finer); "
                                                "used when the voxel size is 0")
    mean_surface: BoolProperty(name="Mean surface", default=True,
                               description="Also import the mean surface with the grids as point attributes")
    density_scale: FloatProperty(name="Density scale", default=0.2, min=0.0,
                                 description="The volume's density is mu (world units^-1) times this")
    threads: IntProperty(name="Threads", default=0, min=0, description="Worker threads; 0: all cores")
    output_dir: StringProperty(name="Output folder", default="", subtype="DIR_PATH",
                               description="Where the .vdb and .ply are kept (the Volume object reads the .vdb "
                                           "from there); empty: next to the .blend file, else a temporary folder")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self, width=360)

    # --- steps

    def _folder(self):
        if self.output_dir:
            folder = bpy.path.abspath(self.output_dir)
        elif bpy.data.filepath:
            folder = bpy.path.abspath("//gpisvdb")
        else:
            folder = os.path.join(tempfile.gettempdir(), "gpisvdb-blender")
        os.makedirs(folder, exist_ok=True)
        return folder

    def _prepare(self, context):
        obj = context.active_object
        exe = find_executable(context)
        folder = self._folder()
        stem = bpy.path.clean_name(obj.name) + "_" + self.task.lower()
        self.mesh_path = os.path.join(folder, stem + "_input.obj")
        self.vdb_path = os.path.join(folder, stem + ".vdb")
        self.ply_path = os.path.join(folder, stem + "_mean.ply")
        self.object_name = obj.name
        write_world_triangles(obj, context.evaluated_depsgraph_get(), self.mesh_path)
        command = [exe, self.task.lower(), self.mesh_path, "-o", self.vdb_path,
                   "--sigma", repr(self.sigma), "--smoothing", repr(self.smoothing), "--threads", str(self.threads)]
        if self.voxel_size > 0:
            command += ["--voxel-size", repr(self.voxel_size)]
        elif self.resolution_scale != 1.0:
            command += ["--resolution-scale", repr(self.resolution_scale)]
        if self.task in ("GREEN", "GEODESIC"):
            c = context.scene.cursor.location
            command += ["--source", f"{c.x!r},{c.y!r},{c.z!r}"]
        commands = [command]
        self.colour_grid = COLOUR_GRID[self.task]
        if self.mean_surface:
            commands.append([exe, "mesh", self.vdb_path, "--grid", "mu", "--grid", self.colour_grid,
                             "--grid", "stddev", "-o", self.ply_path, "--quiet"])
        return Job(commands)

    def _finish(self, context):
        name = f"{self.object_name} GPIS {self.task.lower()}"
        colour_range = (0.0, 1.0)
        surface = None
        if self.mean_surface:
            surface, fields = add_mean_surface(context, name + " mean surface", self.ply_path)
            values = [v for v in fields.get(self.colour_grid, []) if math.isfinite(v)]
            if values:
                colour_range = (min(values), max(values) if max(values) > min(values) else min(values) + 1)
        material = volume_material(name, self.colour_grid, colour_range, self.density_scale)
        volume = add_volume(context, name, self.vdb_path, material)
        for obj in context.selected_objects:
            obj.select_set(False)
        volume.select_set(True)
        context.view_layer.objects.active = volume
        self.report({"INFO"}, f"gpisvdb: {volume.name} from {self.vdb_path}"
                    + (f", mean surface {surface.name}" if surface else ""))

    # --- execution: modal with progress in the UI, blocking in background mode (blender -b)

    def execute(self, context):
        try:
            self.job = self._prepare(context)
            if bpy.app.background:
                self.job.run_to_end()
                self._finish(context)
                return {"FINISHED"}
        except GpisvdbError as e:
            self.report({"ERROR"}, f"gpisvdb: {e}")
            return {"CANCELLED"}
        wm = context.window_manager
        self.timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self.timer)
        wm.progress_end()
        context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            self.job.cancel()
            self._end_modal(context)
            self.report({"WARNING"}, "gpisvdb: cancelled")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            done = self.job.poll()
        except GpisvdbError as e:
            self._end_modal(context)
            self.report({"ERROR"}, f"gpisvdb: {e}")
            return {"CANCELLED"}
        context.window_manager.progress_update(int(100 * self.job.fraction()))
        context.workspace.status_text_set(
            f"gpisvdb: {self.job.stage or 'starting'} {self.job.percent}% (step {self.job.step + 1} of "
            f"{len(self.job.commands)}), Esc to cancel")
        if not done:
            return {"RUNNING_MODAL"}
        self._end_modal(context)
        try:
            self._finish(context)
        except GpisvdbError as e:
            self.report({"ERROR"}, f"gpisvdb: {e}")
            return {"CANCELLED"}
        return {"FINISHED"}


class GPISVDB_preferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    executable: StringProperty(name="gpisvdb program", subtype="FILE_PATH", default="",
                               description="Path of the gpisvdb executable (e.g. build/bin/gpisvdb); "
                                           "empty: $GPISVDB_EXE, then PATH")

    def draw(self, context):
        self.layout.prop(self, "executable")


def menu_entry(self, context):
    self.layout.operator(GPISVDB_OT_from_mesh.bl_idname, text="gpisvdb: GPIS from selected mesh")


CLASSES = (GPISVDB_OT_from_mesh, GPISVDB_preferences)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_object.append(menu_entry)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(menu_entry)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
