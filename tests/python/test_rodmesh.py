"""Tests of the rodmesh Python package against the rodmesh executable.

Run by CTest (tests/CMakeLists.txt) with PYTHONPATH=BUILD/python and
RODMESH_EXE=BUILD/apps/rodmesh; by hand:
    PYTHONPATH=build/python /usr/bin/python3 -m pytest tests/python
"""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
import scipy.sparse

import rodmesh

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXE = os.environ.get("RODMESH_EXE") or os.path.join(
    os.path.dirname(os.path.dirname(rodmesh.__file__)), os.pardir, "apps", "rodmesh")
CANTILEVER = os.path.join(ROOT, "examples", "cantilever.json")
SMALL = os.path.join(ROOT, "tests", "cli", "optimize_small.json")
HAT = os.path.join(ROOT, "examples", "surfaces", "hat.obj")
HAT_DOWN = os.path.join(ROOT, "examples", "surfaces", "hat_front_down.obj")


def cli(*args, check=True):
    r = subprocess.run([EXE, "--quiet", *args], capture_output=True, text=True, timeout=120)
    if check and r.returncode not in (0, 1):
        raise AssertionError("rodmesh %s failed (%d): %s" % (" ".join(args), r.returncode, r.stderr))
    return r


def cli_error(*args):
    r = cli(*args, check=False)
    assert r.returncode == 2, r.stderr
    prefix = "rodmesh: error: "
    assert r.stderr.startswith(prefix), r.stderr
    return r.stderr[len(prefix):].strip()


def assert_same_result(a, b, exact=True):
    """Two Results hold the same archive contents (timings aside)."""
    assert a.status == b.status
    assert a.command == b.command
    assert list(a.poses) == list(b.poses)
    cmp = np.testing.assert_array_equal if exact else (
        lambda x, y: np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-12))
    cmp(a.design.radii, b.design.radii)
    cmp(a.rest_positions, b.rest_positions)
    for name in a.poses:
        p, q = a.poses[name], b.poses[name]
        assert p.status == q.status
        cmp(p.positions, q.positions)
        for key in ("twist", "target", "initial_positions"):
            x, y = getattr(p, key), getattr(q, key)
            assert (x is None) == (y is None), key
            if x is not None:
                cmp(x, y)
        assert (p.rms_error is None) == (q.rms_error is None)
    assert sorted(a.history) == sorted(b.history)
    # Timings, and what the monitor thread had confirmed by each iteration,
    # depend on the machine's load.
    for key in a.history:
        if key not in ("time_s", "phase", "best_rms_error"):
            cmp(np.asarray(a.history[key], float), np.asarray(b.history[key], float))


# ---- scenes

def test_scene_load_dict_json_roundtrip(tmp_path):
    s = rodmesh.Scene.load(CANTILEVER)
    assert s.pose_names == ["self_weight", "tip_load", "sideways"]
    assert s.n_vertices == 11
    d = s.to_dict()
    assert d["format"] == "rodmesh-scene/1"
    s2 = rodmesh.Scene.from_dict(d)
    assert s2.to_dict() == d
    path = tmp_path / "s.json"
    s2.save(path)
    assert rodmesh.Scene.load(path).to_dict() == d
    assert rodmesh.Scene.from_json(s.to_json()).to_dict() == d


def test_bad_scene_raises_the_cli_message(tmp_path):
    d = rodmesh.Scene.load(CANTILEVER).to_dict()
    d["material"]["young_modulus"] = -1.0
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    message = cli_error("simulate", str(path), "-o", str(tmp_path / "out.h5"))
    assert "young_modulus" in message
    with pytest.raises(ValueError) as e:
        rodmesh.Scene.load(path)
    assert str(e.value) == message
    # The same check from a dict; the dict stands for the file.
    with pytest.raises(ValueError) as e:
        rodmesh.Scene.from_dict(d)
    assert str(e.value) == message.replace(str(path), "<dict>")


def test_scene_not_fit_for_optimize_raises_the_cli_message(tmp_path):
    path = tmp_path / "no_design.json"
    path.write_text(rodmesh.Scene.load(CANTILEVER).to_json())
    message = cli_error("optimize", str(path), "-o", str(tmp_path / "out.h5"))
    with pytest.raises(ValueError) as e:
        rodmesh.optimize(rodmesh.Scene.load(path))
    assert str(e.value) == message


# ---- simulate

def test_simulate_matches_the_cli_archive(tmp_path):
    out = tmp_path / "cli.h5"
    cli("simulate", CANTILEVER, "-o", str(out))
    expected = rodmesh.load_archive(out)
    r = rodmesh.simulate(rodmesh.Scene.load(CANTILEVER))
    assert r.status == "converged"
    assert_same_result(r, expected)
    p = r.poses["tip_load"]
    assert p.positions.shape == (11, 3)
    assert p.twist.shape == (10,)
    assert p.positions[10, 2] < -1e-3  # the tip load bends it down
    assert p.residual_norm < 1e-8
    # A stable equilibrium with a positive smallest stiffness, no critical point on its loading path.
    assert p.stable is True
    assert p.smallest_eigenvalue > 0
    assert p.critical_points.shape == (0, 3)
    # The tip load hardly softens the cantilever: far from a critical point.
    assert p.unloaded_smallest_eigenvalue > 0
    assert p.smallest_eigenvalue > 1e-2 * p.unloaded_smallest_eigenvalue
    # Result.save writes what the CLI writes: the CLI reads it back.
    saved = tmp_path / "py.h5"
    r.save(saved)
    assert_same_result(rodmesh.load_archive(saved), expected)
    assert cli("inspect", str(saved)).returncode == 0


HEAP_PROBE = textwrap.dedent("""
    import sys
    import numpy as np
    import rodmesh

    def heap_bytes():
        total = 0
        with open("/proc/self/maps") as f:
            for line in f:
                if line.rstrip().endswith("[heap]"):
                    lo, hi = line.split()[0].split("-")
                    total += int(hi, 16) - int(lo, 16)
        return total

    applied = rodmesh.keep_large_blocks_on_heap() if sys.argv[1] == "policy" else None
    before = heap_bytes()
    block = np.ones(8 << 20)  # 64 MiB, above glibc's largest mmap threshold
    grown = heap_bytes() - before
    del block
    r = rodmesh.simulate(sys.argv[2])
    r.save(sys.argv[3])
    print(applied, grown, heap_bytes() - before)
""")


def test_the_heap_policy_serves_large_blocks_from_the_heap_and_keeps_them(tmp_path):
    """keep_large_blocks_on_heap: a large block comes from the heap (not a
    fresh mapping) and stays there after free; results are unchanged."""
    runs = {}
    for mode in ("default", "policy"):
        out = tmp_path / (mode + ".h5")
        r = subprocess.run([sys.executable, "-c", HEAP_PROBE, mode, CANTILEVER, str(out)], capture_output=True,
                           text=True, timeout=120, env=dict(os.environ))
        assert r.returncode == 0, r.stderr
        applied, grown, kept = r.stdout.split()
        runs[mode] = (applied, int(grown), int(kept), rodmesh.load_archive(out))
    # The heap may already have some free space at its top, which the block
    # takes first: half the block tells heap from mapping.
    half = (64 << 20) // 2
    assert runs["default"][1] < half  # without the policy: a mapping of its own
    assert runs["policy"][0] == "True"
    assert runs["policy"][1] > half  # with it: the heap grows by the block
    assert runs["policy"][2] > half  # and keeps it after free
    assert_same_result(runs["policy"][3], runs["default"][3])


def test_simulate_options_are_the_cli_flags(tmp_path):
    s = rodmesh.Scene.load(CANTILEVER)
    message = cli_error("simulate", CANTILEVER, "-o", str(tmp_path / "o.h5"), "--tol", "5")
    with pytest.raises(ValueError) as e:
        rodmesh.simulate(s, tol=5)
    assert str(e.value) == message
    with pytest.raises(TypeError):
        rodmesh.simulate(s, no_such_option=1)
    out = tmp_path / "cli.h5"
    cli("simulate", CANTILEVER, "-o", str(out), "--max-iter", "1")
    r = rodmesh.simulate(s, max_iter=1)
    assert r.status != "converged"
    assert_same_result(r, rodmesh.load_archive(out))


def test_simulate_dynamic_frames():
    r = rodmesh.simulate(CANTILEVER, dynamic=True, duration=0.02, fps=100)
    f = r.frames["self_weight"]
    assert f["positions"].shape == (len(f["time"]), 11, 3)
    assert len(f["time"]) == 3


# ---- optimize

@pytest.fixture(scope="module")
def small_cli(tmp_path_factory):
    out = tmp_path_factory.mktemp("small") / "cli.h5"
    cli("optimize", SMALL, "-o", str(out))
    return rodmesh.load_archive(out)


def test_optimize_matches_the_cli_archive(small_cli, tmp_path):
    r = rodmesh.optimize(rodmesh.Scene.load(SMALL))
    assert r.status == "converged" == small_cli.status
    assert_same_result(r, small_cli)
    assert r.rms_error < 1e-3 * r.initial_rms_error
    assert r.design.control_points is not None
    assert r.design.control_points.radii.shape[1] == 2
    assert len(r.history["iteration"]) == len(r.history["rms_error"]) >= 2
    assert r.optimize_summary["method"] == "sand"
    # The archived design's imperfection test, in Python as in the archive:
    # radii 0.1% off move these equilibria smoothly.
    for name, p in r.poses.items():
        q = small_cli.poses[name]
        assert p.imperfection_sensitive is False and q.imperfection_sensitive is False
        assert 0 < p.imperfection_gap == q.imperfection_gap
    saved = tmp_path / "py.h5"
    r.save(saved)
    assert_same_result(rodmesh.load_archive(saved), small_cli)


def test_optimize_newton_matches_cli_and_reports_cg(tmp_path):
    out = tmp_path / "cli.h5"
    cli("optimize", SMALL, "-o", str(out), "--method", "newton", "--max-iter", "3")
    seen = []
    r = rodmesh.optimize(SMALL, method="newton", max_iter=3, callback=lambda i: seen.append(i))
    assert r.optimize_summary["method"] == "newton"
    assert r.history["iteration"][-1] <= 3
    assert_same_result(r, rodmesh.load_archive(out))
    steps = [i for i in seen if i["iteration"] > 0]
    assert steps and all(i["cg_iterations"] >= 1 and i["trust_radius"] > 0 for i in steps)


def test_optimize_reduced_with_cli_flags(tmp_path):
    out = tmp_path / "cli.h5"
    cli("optimize", SMALL, "-o", str(out), "--method", "reduced", "--max-iter", "3")
    r = rodmesh.optimize(SMALL, method="reduced", max_iter=3)
    assert r.optimize_summary["method"] == "reduced"
    assert r.history["iteration"][-1] <= 3
    assert_same_result(r, rodmesh.load_archive(out))
    message = cli_error("optimize", SMALL, "-o", str(out), "--threads", "0")
    with pytest.raises(ValueError) as e:
        rodmesh.optimize(SMALL, threads=0)
    assert str(e.value) == message


SHELL = os.path.join(ROOT, "tests", "cli", "shell_targets_small.json")


def test_scene_start_is_the_clis_flag(tmp_path):
    # Shell-made targets: by default the run starts from the rest shape of
    # the pushed pose's target (docs/optimization.md, "The start");
    # scene_start=True, like --scene-start, keeps the scene's.
    out = tmp_path / "cli.h5"
    cli("optimize", SHELL, "-o", str(out), "--max-iter", "1", "--scene-start")
    r = rodmesh.optimize(SHELL, max_iter=1, scene_start=True)
    assert "the run started from" not in r.message
    assert_same_result(r, rodmesh.load_archive(out))
    d = rodmesh.optimize(SHELL, max_iter=1)
    assert "the run started from the rest shape of pose 'lift_twist_push''s target" in d.message
    # How the radius bounds hold the design: Python reads what the CLI wrote.
    b = r.design.control_points.radius_bounds
    assert (b["min"], b["max"]) == (1e-3, 5e-3)
    assert b["elasticity_min"] >= 0 >= b["elasticity_max"]
    assert b == rodmesh.load_archive(out).design.control_points.radius_bounds


def test_callback_sees_every_iteration_and_false_stops(small_cli):
    seen = []

    def callback(info):
        seen.append(info)
        return info["iteration"] < 3

    r = rodmesh.optimize(SMALL, callback=callback)
    assert r.status == "not_converged"
    assert "interrupted" in r.message
    iterations = [i["iteration"] for i in seen]
    assert max(iterations) == 3  # nothing after the stop
    assert {"objective", "rms_error", "constraint_violation", "phase", "level", "time_s"} <= set(seen[0])
    # A usable result: the best design kept, re-solved from rest, better than the start.
    assert all(p.status == "converged" for p in r.poses.values())
    assert r.rms_error < r.initial_rms_error
    assert len(small_cli.history["iteration"]) > len(r.history["iteration"])


def test_callback_exception_stops_and_propagates():
    def callback(info):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        rodmesh.optimize(SMALL, callback=callback)


def test_sigint_stops_optimize_with_a_usable_result(tmp_path):
    # The child slows every iteration down so that the signal lands mid-run.
    script = textwrap.dedent("""
        import json, sys, time
        import rodmesh
        def callback(info):
            print("iteration", info["iteration"], flush=True)
            time.sleep(0.1)
        r = rodmesh.optimize(sys.argv[1], callback=callback)
        print(json.dumps({"status": r.status, "message": r.message, "rms": r.rms_error,
                          "initial": r.initial_rms_error,
                          "iterations": int(r.history["iteration"][-1]),
                          "poses": [p.status for p in r.poses.values()]}), flush=True)
    """)
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(rodmesh.__file__)))
    child = subprocess.Popen([sys.executable, "-c", script, SMALL], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env)
    lines = []
    for line in child.stdout:
        lines.append(line)
        if line.startswith("iteration 2"):
            child.send_signal(signal.SIGINT)
            break
    out, err = child.communicate(timeout=60)
    assert child.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    assert result["status"] == "not_converged"
    assert "interrupted" in result["message"]
    assert result["iterations"] < 10
    assert result["poses"] == ["converged", "converged"]
    assert result["rms"] < result["initial"]


# ---- archives

def test_load_archive_fields(small_cli):
    r = small_cli
    assert r.command == "optimize"
    assert set(r.poses) == {"sag", "lift"}
    V = r.rest_positions.shape[0]
    for p in r.poses.values():
        assert p.positions.shape == (V, 3)
        assert p.target.shape == (V, 3)
        assert p.initial_positions.shape == (V, 3)
        assert p.rms_error == pytest.approx(np.sqrt(np.mean(np.sum((p.positions - p.target) ** 2, 1))))
    assert r.design.radii.shape == (V, 2)
    assert r.design.initial_radii.shape == (V, 2)
    n = len(r.history["iteration"])
    assert all(len(v) == n for v in r.history.values())
    assert r.scene.n_vertices == V
    with pytest.raises(ValueError):
        rodmesh.load_archive(CANTILEVER)  # not an HDF5 archive


# ---- PoseModel

def fd_check(f, df, x, direction, steps=(1e-3, 1e-4, 1e-5)):
    """Central differences of f along `direction` against df(x) @ direction:
    the error falls at second order and ends small."""
    exact = df(x) @ direction
    errors = []
    for h in steps:
        fd = (f(x + h * direction) - f(x - h * direction)) / (2 * h)
        errors.append(np.linalg.norm(fd - exact))
    scale = np.linalg.norm(exact)
    assert scale > 0
    assert errors[-1] < 1e-5 * scale, (errors, scale)
    assert errors[1] < 0.05 * errors[0] or errors[0] < 1e-9 * scale, errors
    return errors


@pytest.mark.parametrize("pose", [0, "lift"])
def test_pose_model_derivatives(pose):
    m = rodmesh.PoseModel(SMALL, pose=pose)
    info = m.dof_info
    assert len(info["kind"]) == m.n_dofs
    u0 = m.rest_state()
    assert u0.shape == (m.n_dofs,)
    # u's meaning: a free vertex's coordinates are its rest position at rest.
    rest = np.asarray(m.scene.to_dict()["vertices"])
    for i in range(0, m.n_dofs, 7):
        if info["kind"][i] == "position" and not info["planar"]:
            assert u0[i] == pytest.approx(rest[info["vertex"][i], info["coordinate"][i]])
    rng = np.random.default_rng(1)
    u = u0 + 1e-4 * rng.standard_normal(m.n_dofs)
    d = rng.standard_normal(m.n_dofs)
    d *= 1e-3 / np.linalg.norm(d)
    fd_check(lambda x: np.array([m.energy(x)]), lambda x: m.gradient(x)[None, :], u, d, steps=(1.0, 0.1, 0.01))
    H = m.hessian(u)
    assert scipy.sparse.issparse(H) and H.shape == (m.n_dofs, m.n_dofs)
    assert abs(H - H.T).max() <= 1e-12 * abs(H).max()  # both triangles
    fd_check(m.gradient, m.hessian, u, d, steps=(1.0, 0.1, 0.01))
    # dF/dp against differences of the gradient in the design.
    p = m.design_vector()
    J = m.design_jacobian(u)
    assert J.shape == (m.n_dofs, m.n_parameters)
    dp = np.zeros_like(p)
    dp[3 * rest.shape[0]:] = 1e-4 * rng.standard_normal(2 * rest.shape[0])  # radii
    dp[: 3 * rest.shape[0]] = 1e-3 * rng.standard_normal(3 * rest.shape[0])  # rest shape
    dp *= 1e-3 / np.linalg.norm(dp)
    fd_check(lambda q: m.gradient(u, q), lambda q: m.design_jacobian(u, q), p, dp, steps=(1.0, 0.1, 0.01))
    fd_check(lambda q: np.array([m.energy(u, q)]), lambda q: m.energy_design_gradient(u, q)[None, :], p, dp,
             steps=(0.1, 0.01, 0.001))
    # The rest state of another design is at rest: no force without loads.
    assert np.linalg.norm(m.gradient(m.rest_state(p + dp), p + dp, load_factor=0)) < 1e-9 * np.linalg.norm(
        m.gradient(u))
    np.testing.assert_allclose(m.material_twists(m.rest_state(p + dp), p + dp), 0, atol=1e-12)
    # No hidden state: the same call gives the same answer after others.
    e = m.energy(u)
    m.hessian(u + 0.01)
    m.energy(u, load_factor=0.5)
    assert m.energy(u) == e


def test_pose_model_twist_dofs_and_equilibrium():
    m = rodmesh.PoseModel(CANTILEVER, pose="tip_load")
    info = m.dof_info
    assert info["kind"].count("twist") == 10
    assert info["kind"].count("position") == 3 * 10  # vertex 0 is clamped
    assert 0 in info["held_vertices"]
    # At the simulated equilibrium the gradient vanishes.
    r = rodmesh.simulate(CANTILEVER)
    x = r.poses["tip_load"].positions
    u = m.rest_state()
    for i, kind in enumerate(info["kind"]):
        if kind == "position":
            u[i] = x[info["vertex"][i], info["coordinate"][i]]
    # twists: the archived twist is the material angle, equal to the unknown
    # with charts at the rest frames.
    for i, kind in enumerate(info["kind"]):
        if kind == "twist":
            u[i] = r.poses["tip_load"].twist[info["edge"][i]]
    g = m.gradient(u)
    assert np.linalg.norm(g) < 1e-6 * np.linalg.norm(m.gradient(m.rest_state()))
    np.testing.assert_allclose(m.positions(u), x, atol=1e-15)
    with pytest.raises(KeyError):
        rodmesh.PoseModel(CANTILEVER, pose="nope")
    with pytest.raises(ValueError):
        m.energy(np.zeros(3))


def test_pose_model_internal_variables_of_a_plastic_tie():
    d = rodmesh.Scene.load(CANTILEVER).to_dict()
    k, f = 50.0, 0.01  # yield stretch 0.2 mm
    d["poses"][0]["ties"] = [{"vertices": [5, 10], "stiffness": k, "yield_force": f}]
    m = rodmesh.PoseModel(rodmesh.Scene.from_dict(d), pose=0)
    x = np.asarray(d["vertices"], float)
    L0 = np.linalg.norm(x[10] - x[5])
    np.testing.assert_allclose(m.initial_internal, [L0], rtol=1e-15)
    u = m.rest_state()
    # At rest the tie has its scene length; shorter rest lengths stretch it:
    # elastic k/2 s^2 up to s = f/k, then f s - f^2/(2k).
    base = m.energy(u, load_factor=0)
    for s in (1e-4, 1e-3):
        e = m.energy(u, load_factor=0, internal=[L0 - s]) - base
        expected = 0.5 * k * s * s if k * s <= f else f * s - 0.5 * f * f / k
        assert e == pytest.approx(expected, rel=1e-9)
    # Gradient and Hessian with the tie in plastic flow, near rest.
    rng = np.random.default_rng(3)
    near = u + 1e-4 * rng.standard_normal(m.n_dofs)
    direction = rng.standard_normal(m.n_dofs)
    direction *= 1e-3 / np.linalg.norm(direction)
    held = [L0 - 1e-3]
    assert np.linalg.norm(m.gradient(near, internal=held) - m.gradient(near)) > 0.5 * f
    fd_check(lambda y: np.array([m.energy(y, internal=held)]), lambda y: m.gradient(y, internal=held)[None, :], near,
             direction, steps=(1.0, 0.1, 0.01))
    fd_check(lambda y: m.gradient(y, internal=held), lambda y: m.hessian(y, internal=held), near, direction,
             steps=(1.0, 0.1, 0.01))
    # The update: the rest length that leaves exactly the yield force.
    np.testing.assert_allclose(m.advanced_internal(u, held), [L0 - f / k], rtol=1e-12)
    np.testing.assert_allclose(m.advanced_internal(u, [L0 - 1e-5]), [L0 - 1e-5], rtol=1e-15)  # elastic
    with pytest.raises(ValueError):
        m.energy(u, internal=[1.0, 2.0])


# ---- meshing

def read_obj(path):
    V, F = [], []
    for line in open(path):
        t = line.split()
        if t and t[0] == "v":
            V.append([float(x) for x in t[1:4]])
        elif t and t[0] == "f":
            F.append([int(x.split("/")[0]) - 1 for x in t[1:4]])
    return np.array(V), np.array(F)


def test_mesh_surface_matches_the_cli(tmp_path):
    out = tmp_path / "hat.json"
    box = [-1, -1, -0.01, 1, 1, 0.001]
    cli("mesh", HAT, "-o", str(out), "--cells", "12", "--pose", HAT_DOWN, "--fix-box", *map(str, box))
    expected = rodmesh.Scene.load(out).to_dict()
    s = rodmesh.mesh_surface(HAT, poses=[HAT_DOWN], cells=12, fix_box=box)
    assert s.to_dict() == expected
    assert s.pose_names == ["hat_front_down"]
    V, F = read_obj(HAT)
    Vd, _ = read_obj(HAT_DOWN)
    s2 = rodmesh.mesh_surface(V, F, poses={"hat_front_down": Vd}, cells=12, fix_box=[box])
    assert s2.to_dict() == expected
    with pytest.raises(ValueError):
        rodmesh.mesh_surface(V, F, poses=[Vd[:5]], cells=12)


def test_grid_matches_the_cli(tmp_path):
    out = tmp_path / "grid.json"
    cli("mesh", "--grid", "hex", "--size", "0.1", "0.1", "--cells", "2", "2", "--rod-vertices", "5",
        "--fix-side", "left", "--pull", "right", "0.5", "0", "0", "-o", str(out))
    s = rodmesh.grid("hex", size=(0.1, 0.1), cells=(2, 2), rod_vertices=5, fix_side="left",
                     pull=("right", 0.5, 0, 0))
    assert s.to_dict() == rodmesh.Scene.load(out).to_dict()
    assert s.pose_names == ["pull_right"]
    d = rodmesh.grid().to_dict()  # the CLI's defaults: hex, 0.2 x 0.2, 4 x 5 cells
    out2 = tmp_path / "default.json"
    cli("mesh", "--grid", "hex", "--size", "0.2", "0.2", "--cells", "4", "5", "-o", str(out2))
    assert d == rodmesh.Scene.load(out2).to_dict()
