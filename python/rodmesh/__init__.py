"""rodmesh from Python: scenes, simulation, design optimization, archives and
the model's derivatives, on the code the ``rodmesh`` command line runs.

    import rodmesh
    scene = rodmesh.Scene.load("examples/cantilever.json")
    result = rodmesh.simulate(scene)
    result.poses["self_weight"].positions      # V x 3 numpy array

See docs/python.md for the whole API.
"""

import json as _json
import os as _os

from . import _rodmesh

try:
    import numpy as _numpy_module
except ImportError:  # `import rodmesh` works without numpy; results need it
    _numpy_module = None


class _NumpyProxy:
    def __getattr__(self, name):
        if _numpy_module is None:
            raise ImportError("rodmesh needs numpy for its results (Debian: python3-numpy; "
                              "the build's Python is %s)" % _rodmesh.python_executable)
        return getattr(_numpy_module, name)


_np = _NumpyProxy()

__all__ = [
    "Scene",
    "Result",
    "PoseResult",
    "Design",
    "PoseModel",
    "simulate",
    "optimize",
    "load_archive",
    "mesh_surface",
    "grid",
    "keep_large_blocks_on_heap",
    "version",
]

version = _rodmesh.version
__version__ = version


class Scene:
    """A validated "rodmesh-scene/1" scene (docs/formats.md section 1).

    Build one with Scene.load(path), Scene.from_dict(d) or Scene.from_json(text),
    or with mesh_surface / grid. Invalid scenes raise ValueError with the
    message the CLI prints (it names the file, the key and the value).
    Scenes are immutable: edit scene.to_dict() and build a new one.
    """

    def __init__(self, impl):
        self._impl = impl

    @classmethod
    def load(cls, path):
        """Reads and validates a scene file."""
        return cls(_rodmesh._Scene.load(_os.fspath(path)))

    @classmethod
    def from_json(cls, text, name="<scene>"):
        """Parses scene JSON text; `name` stands for the file in messages."""
        return cls(_rodmesh._Scene.parse(text, name))

    @classmethod
    def from_dict(cls, d, name="<dict>"):
        """Validates a scene given as a dict (the JSON structure)."""
        return cls.from_json(_json.dumps(d), name)

    def to_dict(self):
        """The scene as a JSON-compatible dict (Scene.from_dict(s.to_dict()) == s)."""
        return _json.loads(self.to_json())

    def to_json(self):
        return self._impl.to_json()

    def save(self, path):
        """Writes the scene as JSON (atomically)."""
        self._impl.save(_os.fspath(path))

    @property
    def pose_names(self):
        return list(self._impl.pose_names)

    @property
    def n_vertices(self):
        return self._impl.n_vertices

    @property
    def source_path(self):
        return self._impl.source_path

    @property
    def warnings(self):
        """Warnings of the last scene parsed (unknown keys and the like)."""
        return list(_rodmesh.last_scene_warnings())

    def __repr__(self):
        return "<rodmesh.Scene %s: %d vertices, poses %s>" % (
            self.source_path, self.n_vertices, ", ".join(self.pose_names))


class PoseResult:
    """One pose of a result: positions (V x 3), twist (E, or None without twist),
    target (V x 3 or None), residual_norm (N), rms_error (m or None), status,
    iterations, time_s; stable (the archived state is a stable equilibrium, or
    None when unknown), smallest_eigenvalue (N/m), unloaded_smallest_eigenvalue
    (N/m, the same of the design's rest state under the pose's supports; a
    stable state with at most 1e-2 of it is at a critical point),
    critical_points (K x 3: load
    factor, smallest eigenvalue N/m, jump m, per critical point the loading path
    passed), out_of_plane_stable (planar solves); optimize only:
    initial_positions (the equilibrium under the initial design),
    equilibrium_gap (m), imperfection_sensitive (with every radius changed by
    0.1% the loading path reaches an equilibrium more than a tenth of the
    largest displacement away, or none; None when not judged) and
    imperfection_gap (m, that distance; None when such a solve failed)."""

    def __init__(self, d):
        self.__dict__.update(d)

    def __repr__(self):
        rms = "" if self.rms_error is None else ", RMS %.4g mm" % (self.rms_error * 1e3)
        return "<rodmesh.PoseResult %r: %s%s>" % (self.name, self.status, rms)


class ControlPoints:
    """The design's control points (optimize only): radii (C x 2),
    rest_displacement (C x 3), rod, arc_fraction, vertex (C each);
    radius_bounds (radii free, the final design; else None): a dict with min
    and max (m, the bounds in use), at_min and at_max (how many of the 2C
    control radius values the bound holds: it stopped them, and the
    objective falls past it) and elasticity_min >= 0, elasticity_max <= 0
    (d ln objective / d ln bound, first order: a minimum 1% lower lowers the
    objective by about elasticity_min %)."""

    def __init__(self, d):
        self.__dict__.update(d)


class Design:
    """radii (V x 2, [r_t, r_n] per vertex), rest_positions (V x 3),
    initial_radii (optimize only), control_points (ControlPoints or None)."""

    def __init__(self, radii, rest_positions, initial_radii, control_points):
        self.radii = radii
        self.rest_positions = rest_positions
        self.initial_radii = initial_radii
        self.control_points = control_points


class Result:
    """What simulate / optimize return and load_archive reads: the contents of
    a "rodmesh-archive/1" file (docs/formats.md section 3).

    status: "converged", "not_converged" or "failed"; message: why it stopped;
    poses: dict name -> PoseResult (in scene order); design: Design;
    rest_positions: the design's rest shape; history: dict of numpy arrays, one
    entry per optimizer iteration (optimize only, else {}); rms_error: the RMS
    error over every pose and vertex (m, None without targets);
    save(path) writes the archive the CLI writes.
    """

    def __init__(self, archive):
        self._archive = archive
        d = archive.to_dict()
        self.status = d["status"]
        self.message = d["message"]
        self.command = d["command"]
        self.version = d["version"]
        self.model = d["model"]
        self.scene_json = d["scene_json"]
        self.attributes = d["attributes"]
        self.optimize_summary = d["optimize"]
        self.poses = {p["name"]: PoseResult(p) for p in d["poses"]}
        cp = d["control_points"]
        self.design = Design(d["radii"], d["rest_positions"], d["initial_radii"],
                             ControlPoints(cp) if cp is not None else None)
        self.rest_positions = d["rest_positions"]
        self.history = dict(d["history"]) if d["history"] is not None else {}
        self.frames = {f["name"]: f for f in d["frames"]}

    @property
    def converged(self):
        return self.status == "converged"

    @property
    def rms_error(self):
        """RMS distance to the targets over every pose and vertex (m), or None."""
        total, count = 0.0, 0
        for p in self.poses.values():
            if p.target is None:
                return None
            total += float(_np.sum((p.positions - p.target) ** 2))
            count += p.positions.shape[0]
        return (total / count) ** 0.5 if count else None

    @property
    def initial_rms_error(self):
        """RMS error of the initial design (optimize only), or None."""
        total, count = 0.0, 0
        for p in self.poses.values():
            if p.target is None or p.initial_positions is None:
                return None
            total += float(_np.sum((p.initial_positions - p.target) ** 2))
            count += p.positions.shape[0]
        return (total / count) ** 0.5 if count else None

    @property
    def scene(self):
        """The scene the result was computed for."""
        return Scene.from_json(self.scene_json, "<archive scene>")

    def save(self, path):
        """Writes the HDF5 archive (the same file `rodmesh simulate/optimize -o` writes)."""
        self._archive.save(_os.fspath(path))

    def __repr__(self):
        rms = self.rms_error
        return "<rodmesh.Result %s %s%s: %s>" % (
            self.command, self.status, "" if rms is None else ", RMS %.4g mm" % (rms * 1e3),
            ", ".join(self.poses))


def _scene_of(scene):
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return Scene.from_dict(scene)
    if isinstance(scene, (str, _os.PathLike)):
        return Scene.load(scene)
    raise TypeError("scene must be a rodmesh.Scene, a dict or a path, got %s" % type(scene).__name__)


def simulate(scene, quiet=True, **options):
    """Static equilibrium of every pose (or with dynamic=True, duration=T the
    motion from rest), as `rodmesh simulate`. Options are the CLI's flags:
    tol, max_iter, static_solver ('newton' | 'relaxation'), time_limit,
    dynamic, duration, fps, max_step, ramp. quiet=False prints the CLI's
    progress lines on stderr. Returns a Result. Ctrl-C stops the solve."""
    s = _scene_of(scene)
    return Result(_rodmesh.simulate(s._impl, options, quiet))


def optimize(scene, method=None, callback=None, quiet=True, **options):
    """Designs radii and rest shape so that every pose reaches its target, as
    `rodmesh optimize`. method: 'sand' (default when built with Ipopt) or
    'reduced'. Options are the CLI's flags: max_iter, time_limit, tol,
    schedule ('paper' | 'joint' | 'levels' | 'multilevel'), threads (default:
    the machine's hardware threads; the result does not depend on it),
    design_derivatives ('exact' | 'fd' | 'fd-resolve'), ipopt (dict or list of
    'KEY=VALUE'), no_imperfection_back_off (bool), scene_start (bool).

    callback(info) is called once per iteration with the progress line's
    fields (iteration, level, phase, objective, rms_error, constraint_violation,
    dual_infeasibility, gradient_norm, step, time_s, best_rms_error,
    best_iteration); returning False stops the run as SIGINT stops the CLI:
    the best design found is kept and re-solved, and the Result's status is
    not_converged. Ctrl-C (KeyboardInterrupt) does the same. An exception in
    the callback stops the run and is re-raised."""
    s = _scene_of(scene)
    if method is not None:
        options["method"] = method
    if not quiet:
        callback = _printing(callback)
    return Result(_rodmesh.optimize(s._impl, options, callback, quiet))


def _printing(callback):
    """Prints a progress line per iteration (quiet=False), then calls `callback`."""
    import sys

    def wrapped(info):
        best = ""
        if info["best_iteration"] >= 0:
            best = "  best %.4f mm @%d" % (info["best_rms_error"] * 1e3, info["best_iteration"])
        print("iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  viol %.2e N  |g| %.2e  step %.2e  %.2f s%s" % (
            info["iteration"], info["level"], info["phase"], info["objective"], info["rms_error"] * 1e3,
            info["constraint_violation"], info["gradient_norm"], info["step"], info["time_s"], best),
            file=sys.stderr, flush=True)
        return None if callback is None else callback(info)
    return wrapped


def keep_large_blocks_on_heap():
    """Applies the `rodmesh` executable's heap policy to this process.

    glibc maps every large block afresh and unmaps it on free; the
    factorizations of simulate and optimize allocate and zero their
    workspaces at every Newton or Ipopt iteration, so each iteration faults
    those pages in again. After this call large blocks come from the heap
    and freed memory stays there for reuse (docs/python.md, "Speed"). The
    policy is process-wide and not undone: memory freed later (by any
    library, numpy included) is not given back to the system until the
    process exits. Meant for scripts that run large optimizations, not for
    long-lived notebooks. Returns True if it took effect (glibc), else False.
    """
    return bool(_rodmesh.keep_large_blocks_on_heap())


def load_archive(path):
    """Reads and validates an archive written by the CLI or Result.save."""
    return Result(_rodmesh.load_archive(_os.fspath(path)))


def _internal(values):
    return None if values is None else _np.asarray(values, float)


class PoseModel:
    """The energy of one pose of a scene as a function of its unknowns u, with
    exact derivatives (model/pose_system.hh).

    Unknowns u (dof_info says what each entry is): for every free vertex, in
    vertex order, its position (3 coordinates, or 2 in-plane coordinates along
    dof_info['plane_basis'] from dof_info['plane_origin'] for planar scenes);
    then, if twist is simulated, one twist angle per edge (rad, 0 at rest).
    Held vertices are not unknowns.

    Design parameters p (design_vector()): 3 rest coordinates per vertex, then
    2 radii [r_t, r_n] per vertex.

    Every method takes the state explicitly: u, optionally p (default: the
    scene's design) and load_factor (1: the pose as given; it scales loads and
    prescribed displacements). Twists are measured from the rest frames of
    the scene's design whatever p is (fixed coordinates, so that design
    derivatives are taken at fixed u); results depend only on the arguments.

    Internal variables (initial_internal): values some energy terms keep in
    the state, today the rest length of each plastic tie (scene key
    poses[i].ties, one value per tie). energy, gradient and hessian take them
    as `internal` (default: the initial values); advanced_internal applies
    the terms' update rules (a tie yields) at u.
    """

    def __init__(self, scene, pose=0):
        s = _scene_of(scene)
        if isinstance(pose, str):
            names = s.pose_names
            if pose not in names:
                raise KeyError("no pose named %r (poses: %s)" % (pose, ", ".join(names)))
            pose = names.index(pose)
        self.scene = s
        self._impl = _rodmesh._PoseModel(s._impl, int(pose))
        self.dof_info = self._impl.dof_info()

    @property
    def pose(self):
        return self._impl.pose

    @property
    def pose_name(self):
        return self._impl.pose_name

    @property
    def n_dofs(self):
        return self._impl.n_dofs

    @property
    def n_parameters(self):
        return self._impl.n_parameters

    def design_vector(self):
        """p of the scene's design: rest positions (3 per vertex), then radii (2 per vertex)."""
        return self._impl.design_vector()

    def rest_state(self, p=None):
        """u of the rest configuration of design p (twist unknowns are zero for
        the scene's design only)."""
        return self._impl.rest_state(p)

    def energy(self, u, p=None, load_factor=1.0, internal=None):
        """Total potential energy E(u, p) (J)."""
        return self._impl.energy(_np.asarray(u, float), p, load_factor, _internal(internal))

    def gradient(self, u, p=None, load_factor=1.0, internal=None):
        """dE/du: the equilibrium residual (N for positions, N m for twists)."""
        return self._impl.gradient(_np.asarray(u, float), p, load_factor, _internal(internal))

    def hessian(self, u, p=None, load_factor=1.0, internal=None):
        """d2E/du2 as a scipy.sparse matrix, both triangles stored."""
        return self._impl.hessian(_np.asarray(u, float), p, load_factor, _internal(internal))

    @property
    def initial_internal(self):
        """The internal variables' initial values (a tie's: its scene length, m)."""
        return self._impl.initial_internal

    def advanced_internal(self, u, internal=None, p=None, load_factor=1.0):
        """The internal variables after the terms' update rules at u (a tie
        whose tension exceeds its yield force gets the rest length that leaves
        exactly that force); unchanged values where nothing yields."""
        return self._impl.advanced_internal(_np.asarray(u, float), _internal(internal), p, load_factor)

    def design_jacobian(self, u, p=None, load_factor=1.0):
        """dF/dp = d2E/du dp (n_dofs x n_parameters) as a scipy.sparse matrix."""
        return self._impl.design_jacobian(_np.asarray(u, float), p, load_factor)

    design_derivatives = design_jacobian

    def energy_design_gradient(self, u, p=None, load_factor=1.0):
        """dE/dp (n_parameters)."""
        return self._impl.energy_design_gradient(_np.asarray(u, float), p, load_factor)

    def positions(self, u, p=None, load_factor=1.0):
        """Every vertex's position (V x 3), held vertices at their prescribed positions."""
        return self._impl.positions(_np.asarray(u, float), p, load_factor)

    def material_twists(self, u, p=None, load_factor=1.0):
        """Each edge's material-frame angle from the design's transported rest frame."""
        return self._impl.material_twists(_np.asarray(u, float), p, load_factor)

    def __repr__(self):
        return "<rodmesh.PoseModel pose %d %r: %d unknowns, %d design parameters>" % (
            self.pose, self.pose_name, self.n_dofs, self.n_parameters)


def _poses_list(poses):
    if poses is None:
        return []
    if isinstance(poses, dict):
        return [(str(k), v) for k, v in poses.items()]
    out = []
    for i, p in enumerate(poses):
        if isinstance(p, tuple):
            name, v = p
            out.append((str(name), v if isinstance(v, str) else _np.asarray(v, float)))
        elif isinstance(p, (str, _os.PathLike)):
            out.append(("", _os.fspath(p)))  # named after the file, as the CLI does
        else:
            out.append(("pose_%d" % (i + 1), _np.asarray(p, float)))
    return out


def mesh_surface(V, F=None, poses=None, **options):
    """A rod-mesh scene from a triangle surface, as `rodmesh mesh`: V is a
    path (.obj, .off, .ply) or an N x 3 vertex array with F (M x 3 faces);
    poses are deformed copies (same faces), one target pose each: a list of
    paths (named after the file), of N x 3 arrays (named pose_1, ...), of
    (name, path or array) pairs, or a dict name -> array. Options are the
    CLI's flags with their defaults: cells (64), dual, faces_target
    (--faces), iterations, merge, refinement, restarts, tolerance, boundary
    ('rim' | 'free'), edge_length, fix_box (six numbers or a list of them),
    fix_vertices, density, scale, young_modulus, poisson_ratio,
    material_density, radius, radius_bounds, design, control_points, gravity.
    Returns a Scene."""
    if not _rodmesh.have_meshing:
        raise RuntimeError("rodmesh was built without the meshing module (CGAL)")
    if isinstance(V, _os.PathLike):
        V = _os.fspath(V)
    if not isinstance(V, str):
        V = _np.asarray(V, float)
        if F is None:
            raise ValueError("mesh_surface: vertices V need faces F (M x 3)")
        F = _np.asarray(F, _np.int64)
    return Scene(_rodmesh.mesh_surface(V, F, _poses_list(poses), options))


def grid(kind="hex", **options):
    """A generated planar sheet in z = 0, as `rodmesh mesh --grid KIND`: kind
    'hex' | 'quad' | 'tri'; size (W, H) in m (0.2, 0.2), cells (NX, NY) (4, 5),
    rod_vertices (11), fit ('regular' | 'stretch'), hex_rows, fix_side (a side
    or a list: 'left', 'right', 'bottom', 'top'), pull ((side, fx, fy, fz) or
    a list of them), and the material, radius and design options of
    mesh_surface. Returns a Scene."""
    if not _rodmesh.have_meshing:
        raise RuntimeError("rodmesh was built without the meshing module")
    return Scene(_rodmesh.grid(kind, options))
