"""The Python module pipetile, end to end: real .vdb files written by the CLI and by pyopenvdb, the
real CLI on the same input, numpy volumes and pyopenvdb grids. ctest runs it with Debian's python3
(CMakeLists.txt, test "Python"), with PIPETILE_CLI, PIPETILE_SOURCE_DIR and PIPETILE_BUILD_DIR set."""

import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import meshio
import numpy as np
import pyopenvdb as vdb
import pytest

import pipetile

CLI = os.environ["PIPETILE_CLI"]
SOURCE_DIR = Path(os.environ["PIPETILE_SOURCE_DIR"])
BUILD_DIR = Path(os.environ["PIPETILE_BUILD_DIR"])


def run(*args, cwd=None, env=None):
    return subprocess.run([str(a) for a in args], cwd=cwd, env=env, check=True, capture_output=True, text=True)


@pytest.fixture(scope="module")
def phantom(tmp_path_factory):
    """The bundled phantom (a 256 x 256 x 512 level set tube), written by the CLI."""
    path = tmp_path_factory.mktemp("phantom") / "phantom.vdb"
    run(CLI, "sample", "phantom", "-o", path)
    return path


@pytest.fixture(scope="module")
def phantom_levels(phantom):
    return pipetile.mesh(phantom)


@pytest.fixture(scope="module")
def cli_levels(phantom, tmp_path_factory):
    """`pipetile mesh` on the same file: its report and each level's PLY, read by meshio."""
    out = tmp_path_factory.mktemp("cli")
    run(CLI, "mesh", phantom, "-o", out / "phantom.ply", "--report", out / "report.json")
    report = json.loads((out / "report.json").read_text())
    return report, [meshio.read(out / f"phantom_L{k}.ply") for k in range(len(report["levels"]))], out


def rows(points):
    """The rows of an (N, 3) array as a sorted multiset, for comparing vertex sets."""
    return points[np.lexsort(points.T[::-1])]


def triangles_by_position(points, faces):
    """Each triangle as its three corners, rotated to start at its smallest corner (orientation
    kept), then sorted: the mesh up to the numbering of its vertices."""
    corners = points[faces]  # (M, 3, 3)
    keys = [tuple(map(tuple, t)) for t in corners]
    rotated = [min(k[i:] + k[:i] for i in range(3)) for k in keys]
    return sorted(rotated)


def same_levels(a, b):
    return np.array_equal(a.vertices, b.vertices) and a.vertex_counts == b.vertex_counts and all(
        np.array_equal(x.faces, y.faces) for x, y in zip(a, b))


# --- Nested levels ----------------------------------------------------------------------------


def test_levels_share_one_coarse_first_vertex_array(phantom_levels):
    levels = phantom_levels
    assert len(levels) == 4  # the default, as the CLI's
    assert levels.vertices.dtype == np.float64 and levels.vertices.shape == (levels.vertex_counts[-1], 3)
    assert not levels.vertices.flags.writeable  # shared by every level
    for level in levels:
        assert level.faces.dtype == np.int32 and level.faces.shape[1] == 3
        # A prefix of the shared array, not a copy.
        assert level.vertices.base is not None and np.shares_memory(level.vertices, levels.vertices)
        assert level.vertices.shape == (level.vertex_count, 3)
        # Every vertex of the level is used by its faces, and no face reaches past the prefix.
        assert set(np.unique(level.faces)) == set(range(level.vertex_count))
        assert level.vertex_count == level.report["vertices"]
        assert len(level.faces) == level.report["triangles"]
    assert levels.vertex_counts == sorted(levels.vertex_counts)


def test_levels_nest_as_prefixes_of_the_finest_like_the_cli(phantom_levels, cli_levels):
    # Level L of the CLI, written on its own, has exactly the first vertex_count[L] vertices of the
    # module's array: the coarse-first order makes every level a prefix.
    report, meshes, _ = cli_levels
    for level, written in zip(phantom_levels, meshes):
        prefix = phantom_levels.vertices[: level.vertex_count].astype(written.points.dtype)
        assert np.array_equal(rows(prefix), rows(written.points))


# --- Agreement with the CLI -------------------------------------------------------------------


def test_same_triangles_and_vertices_as_the_cli(phantom_levels, cli_levels):
    report, meshes, _ = cli_levels
    assert len(phantom_levels) == len(report["levels"])
    for level, cli_level, written in zip(phantom_levels, report["levels"], meshes):
        assert len(level.faces) == cli_level["triangles"]
        assert level.vertex_count == cli_level["vertices"]
        # The same triangles on the same points, at the precision the file stores.
        points = level.vertices.astype(written.points.dtype)
        assert triangles_by_position(points, level.faces) == triangles_by_position(
            written.points, written.cells_dict["triangle"])


def test_report_has_the_cli_fields(phantom_levels, cli_levels):
    report, _, _ = cli_levels
    ours = phantom_levels.report
    assert set(ours) == set(report)
    for key in ("statistics", "events", "graph"):
        assert set(ours[key]) == set(report[key])
    # The levels' entries: the CLI's, except the file it wrote.
    for entry, cli_entry in zip(ours["levels"], report["levels"]):
        assert set(entry) == set(cli_entry) - {"file"}
    # Same input, same decisions: everything but the timings agrees.
    timing = re.compile(r"seconds$")

    def without_timings(value):
        if isinstance(value, dict):
            return {k: without_timings(v) for k, v in value.items() if not timing.search(k) and k != "file"}
        if isinstance(value, list):
            return [without_timings(v) for v in value]
        return value

    assert without_timings(ours) == without_timings(report)
    # One tube, closed: Euler characteristic 2 at every level (README's phantom).
    assert [entry["euler"] for entry in ours["levels"]] == [2] * 4


# --- Other sources: numpy volumes and pyopenvdb grids -----------------------------------------


def read_grid(path):
    name = vdb.readAllGridMetadata(str(path))[0].name
    return vdb.read(str(path), name)


def dense_from_origin(grid):
    """The grid's values over voxels [0, max] of its active box (the phantom's box lies at positive
    indices), so that array[i, j, k] is voxel (i, j, k) and no index shift enters the comparison."""
    (lo, hi) = grid.evalActiveVoxelBoundingBox()
    assert min(lo) >= 0
    array = np.empty([h + 1 for h in hi], dtype=np.float32)
    grid.copyToArray(array, ijk=(0, 0, 0))
    return array


def test_numpy_level_set_equals_the_vdb(phantom, phantom_levels):
    grid = read_grid(phantom)
    array = dense_from_origin(grid)
    levels = pipetile.mesh(array, voxel_size=grid.transform.voxelSize()[0], origin=(0, 0, 0), grid_class="level set")
    assert same_levels(levels, phantom_levels)
    # index_to_world is the same placement, written as a matrix.
    matrix = np.diag([*grid.transform.voxelSize(), 1.0])
    assert same_levels(pipetile.mesh(array, index_to_world=matrix, grid_class="level set"), phantom_levels)
    assert levels.report["input"] == "numpy array " + "x".join(map(str, array.shape))


def test_pyopenvdb_grid_equals_the_vdb(phantom, phantom_levels):
    grid = read_grid(phantom)
    active = grid.activeVoxelCount()
    levels = pipetile.mesh(grid)
    assert same_levels(levels, phantom_levels)
    assert levels.report["grid"] == grid.name and levels.report["input"] == "pyopenvdb grid"
    # Meshed from a copy: the caller's grid is left as it was.
    assert grid.activeVoxelCount() == active


def capsule_density(shape=(40, 40, 64), radius=8.0):
    """A fog volume: density 1 inside a capsule along z, 0 outside, a two-voxel ramp between."""
    i, j, k = np.indices(shape, dtype=np.float64)
    centre = (np.array(shape) - 1) / 2
    z = np.clip(k, 16, shape[2] - 17)
    distance = np.sqrt((i - centre[0]) ** 2 + (j - centre[1]) ** 2 + (k - z) ** 2)
    return np.clip((radius - distance) / 2 + 0.5, 0.0, 1.0).astype(np.float32)


def test_numpy_fog_equals_the_vdb(tmp_path):
    density = capsule_density()
    grid = vdb.FloatGrid(0.0)
    grid.copyFromArray(density, ijk=(0, 0, 0), tolerance=0)
    grid.gridClass = vdb.GridClass.FOG_VOLUME
    grid.name = "density"
    path = tmp_path / "capsule.vdb"
    vdb.write(str(path), grids=[grid])
    from_file = pipetile.mesh(path)
    # Halfway from the background (0) to the densest value (1), as for a .vdb.
    assert from_file.report["iso"] == 0.5 and from_file.report["class"] == "fog volume"
    from_array = pipetile.mesh(density, grid_class="fog", grid="density")
    assert same_levels(from_array, from_file)
    assert from_array.report["iso"] == 0.5 and from_array.report["grid"] == "density"
    assert same_levels(pipetile.mesh(grid), from_file)


def test_anisotropic_voxels_place_vertices_in_world_space(tmp_path):
    # The same density with voxels twice as long in y lands at twice the y, the same x and z. (Across
    # the slicing axis: along it, end contours keep quarters of the smallest voxel edge inside the
    # end, fewer voxels of a longer axis, and the mesh in index space differs.)
    density = capsule_density()
    unit = pipetile.mesh(density, grid_class="fog", axis="z", levels=1)
    stretched = pipetile.mesh(density, grid_class="fog", axis="z", levels=1, voxel_size=(1, 2, 1), origin=(5, 0, 0))
    assert np.array_equal(stretched.vertices[:, 0], unit.vertices[:, 0] + 5)
    assert np.array_equal(stretched.vertices[:, 1], unit.vertices[:, 1] * 2)
    assert np.array_equal(stretched.vertices[:, 2], unit.vertices[:, 2])


# --- Validation -------------------------------------------------------------------------------


def test_validate_gives_the_cli_validation(phantom, phantom_levels, cli_levels, tmp_path):
    finest = phantom_levels[-1]
    ours = pipetile.validate(phantom, finest.vertices, finest.faces)
    _, _, out = cli_levels
    run(CLI, "validate", phantom, out / "phantom_L3.ply", "--report", tmp_path / "v.json")
    theirs = json.loads((tmp_path / "v.json").read_text())["validation"]
    assert set(ours) == set(theirs)
    # A closed, outward, one-tube mesh within a voxel of the isosurface (the README's phantom).
    assert ours["closed"] and ours["manifold"] and ours["oriented"] and ours["outward"]
    assert ours["euler"] == 2 and ours["components"] == 1
    assert ours["hausdorff_voxels"] < 1.0
    assert theirs["euler"] == ours["euler"]


# --- Errors -----------------------------------------------------------------------------------


def test_library_errors_are_pipetile_errors_with_its_messages(tmp_path):
    with pytest.raises(pipetile.Error, match="no such file; check the path") as missing:
        pipetile.mesh(tmp_path / "missing.vdb")
    assert str(tmp_path / "missing.vdb") in str(missing.value)
    assert not isinstance(missing.value, ValueError)
    not_vdb = tmp_path / "text.vdb"
    not_vdb.write_text("not a volume")
    with pytest.raises(pipetile.Error, match="not a readable VDB file"):
        pipetile.mesh(not_vdb)
    with pytest.raises(pipetile.Error, match="NaN or infinite"):
        density = capsule_density()
        density[3, 4, 5] = np.nan
        pipetile.mesh(density, grid_class="fog")
    with pytest.raises(pipetile.Error, match="empty"):
        pipetile.mesh(np.zeros((8, 8, 8)), grid_class="fog")


def test_names_that_are_no_utf8_are_taken_and_given_back_as_os_fsdecode_makes_them(tmp_path):
    """File and grid names are bytes: Latin-1 ones are no UTF-8. pipetile takes them as os.fsencode
    gives them back (str with surrogates, or bytes) and names them so in its errors; the report, JSON
    and therefore UTF-8, has U+FFFD for those bytes, as the CLI's has. pybind11's strict decoding
    refused such a path (TypeError) and could not raise an error naming one."""
    sphere = vdb.createLevelSetSphere(6.0, voxelSize=1.0)
    sphere.name = "QQQQ"
    plain = tmp_path / "plain.vdb"
    vdb.write(str(plain), grids=[sphere])
    data = plain.read_bytes()
    assert data.count(b"QQQQ") >= 1
    path = os.fsdecode(os.fsencode(tmp_path) + b"/caf\xe9.vdb")
    Path(path).write_bytes(data.replace(b"QQQQ", b"\xe9QQQ"))  # same length: still a valid file
    levels = pipetile.mesh(path, levels=1)
    assert levels.report["grid"] == "\ufffdQQQ"
    assert levels.report["input"].endswith("caf\ufffd.vdb")
    subprocess.run([CLI, "mesh", path, "--levels", "1", "-o", tmp_path / "m.ply", "--report", tmp_path / "r.json"],
                   check=True, capture_output=True)  # its table shows the name's bytes as they are
    assert json.loads((tmp_path / "r.json").read_text())["grid"] == levels.report["grid"]
    for name in ("\udce9QQQ", b"\xe9QQQ"):
        picked = pipetile.mesh(os.fsencode(path), grid=name, levels=1)
        assert np.array_equal(picked[0].faces, levels[0].faces)
    with pytest.raises(pipetile.Error, match="no grid named 'QQQQ'") as unknown:
        pipetile.mesh(path, grid="QQQQ", levels=1)
    assert "'\udce9QQQ'" in str(unknown.value) and path in str(unknown.value)
    missing = os.fsdecode(os.fsencode(tmp_path) + b"/gon\xe9.vdb")
    with pytest.raises(pipetile.Error, match="no such file") as gone:
        pipetile.mesh(missing)
    assert missing in str(gone.value)


def test_bad_arguments_are_value_errors(phantom):
    density = capsule_density()
    cases = [
        (lambda: pipetile.mesh(phantom, levels=0), "levels must be between 1 and 16"),
        (lambda: pipetile.mesh(phantom, rays=2), "rays must be between 3 and 4096"),
        (lambda: pipetile.mesh(phantom, spacing=0), "spacing must be between"),
        (lambda: pipetile.mesh(phantom, axis="w"), "axis 'w'"),
        (lambda: pipetile.mesh(phantom, tiler="best"), "tiler 'best'"),
        (lambda: pipetile.mesh(phantom, voxel_size=2), "apply to numpy volumes only"),
        (lambda: pipetile.mesh(density), "needs grid_class"),
        (lambda: pipetile.mesh(density[0], grid_class="fog"), "3-D array"),
        (lambda: pipetile.mesh(density.astype(complex), grid_class="fog"), "real numbers"),
        (lambda: pipetile.mesh(density, grid_class="fog", voxel_size=-1), "voxel_size"),
        (lambda: pipetile.mesh(density, grid_class="fog", origin=(0, 0)), "origin"),
        (lambda: pipetile.mesh(density, grid_class="fog", index_to_world=np.eye(3)), "4x4"),
        (lambda: pipetile.mesh(density, grid_class="fog", index_to_world=np.zeros((4, 4)) + np.diag([0, 0, 0, 1])),
         "singular"),
        # OpenVDB's row-vector matrix, translation in the last row: must be transposed.
        (lambda: pipetile.mesh(density, grid_class="fog", index_to_world=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
                                                                           [5, 0, 0, 1]]), "last row"),
        (lambda: pipetile.mesh(vdb.Vec3SGrid()), "pipetile meshes a pyopenvdb.FloatGrid"),
        (lambda: pipetile.validate(phantom, np.zeros((3, 3)), [[0, 1, 3]]), "names vertex 3, but there are 3"),
        (lambda: pipetile.validate(phantom, np.zeros((3, 2)), [[0, 1, 2]]), r"\(N, 3\)"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message) as error:
            call()
        assert isinstance(error.value, pipetile.Error)


# --- Converters -------------------------------------------------------------------------------


def test_converters(phantom_levels, tmp_path):
    level = phantom_levels[1]
    vertices, faces = level.as_tuple()
    assert vertices is level.vertices and faces is level.faces
    mesh = level.to_meshio()
    assert np.array_equal(mesh.points, level.vertices)
    assert np.array_equal(mesh.cells_dict["triangle"], level.faces)
    mesh.write(tmp_path / "level.obj")
    back = meshio.read(tmp_path / "level.obj")
    assert back.points.shape == (level.vertex_count, 3) and len(back.cells_dict["triangle"]) == len(level.faces)


def test_meshio_is_imported_only_when_asked_for(phantom):
    code = ("import sys, pipetile; levels = pipetile.mesh(sys.argv[1], levels=1); "
            "assert 'meshio' not in sys.modules; levels[0].to_meshio(); assert 'meshio' in sys.modules")
    run(sys.executable, "-c", code, phantom)


# --- The GIL ----------------------------------------------------------------------------------


def test_other_threads_run_while_it_meshes(phantom):
    # Were the GIL held through the C++ work, this thread could not run until mesh returned: its
    # longest pause would be the whole call. Released, its pauses are the interpreter's switches.
    done = threading.Event()
    span = {}

    def work():
        start = time.perf_counter()
        pipetile.mesh(phantom, levels=8, threads=1)
        span["seconds"] = time.perf_counter() - start
        done.set()

    worker = threading.Thread(target=work)
    last = time.perf_counter()
    longest = 0.0
    worker.start()
    while not done.is_set():
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    worker.join()
    assert span["seconds"] > 0.3, "too little work to tell"
    assert longest < span["seconds"] / 2


# --- README and install -----------------------------------------------------------------------


def test_readme_python_example_runs(phantom, phantom_levels, tmp_path):
    readme = (SOURCE_DIR / "README.md").read_text()
    example = re.search(r"## Python\n.*?```python\n(.*?)```", readme, re.S).group(1)
    assert len(example.strip().splitlines()) == 5
    (tmp_path / "vessel.vdb").symlink_to(phantom)
    result = run(sys.executable, "-c", example, cwd=tmp_path)
    written = meshio.read(tmp_path / "vessel.ply")
    assert len(written.cells_dict["triangle"]) == len(phantom_levels[-1].faces)
    assert float(result.stdout.strip()) < 1.0  # the finest level, within a voxel


def test_cmake_install_puts_the_module_where_debian_python_finds_it(phantom, tmp_path, phantom_levels):
    stage = tmp_path / "stage"
    run("cmake", "--install", BUILD_DIR, env={**os.environ, "DESTDIR": str(stage)})
    installed = [p.parent for p in stage.rglob("pipetile/__init__.py")]
    assert len(installed) == 1
    site = "/" + str(installed[0].parent.relative_to(stage))
    debian_path = run("/usr/bin/python3", "-c", "import sys; print('\\n'.join(sys.path))").stdout.split()
    assert site in debian_path
    # The staged copy imports and meshes on its own (its libpipetile.so, if shared, is staged too).
    libdirs = ":".join(str(p.parent) for p in stage.rglob("libpipetile.so*"))
    env = {**os.environ, "PYTHONPATH": str(stage / site.lstrip("/")), "LD_LIBRARY_PATH": libdirs}
    code = "import sys, pipetile; print(pipetile.__file__, len(pipetile.mesh(sys.argv[1])[-1].faces))"
    where, triangles = run("/usr/bin/python3", "-c", code, phantom, cwd=tmp_path, env=env).stdout.split()
    assert where.startswith(str(stage))
    assert int(triangles) == len(phantom_levels[-1].faces)


def write_sphere_frames(folder, frames):
    """Frame f: a level set sphere of radius 4 + f / 2 voxels, so each frame's mesh is its own."""
    for f in frames:
        sphere = vdb.createLevelSetSphere(radius=4.0 + 0.5 * f, center=(0, 0, 0), voxelSize=1.0, halfWidth=3.0)
        sphere.name = "sphere"
        vdb.write(str(folder / f"seq.{f:04d}.vdb"), grids=[sphere])


def test_dask_local_cluster_writes_the_cli_batch_files(tmp_path):
    """pipetile.dask.mesh_frames on a LocalCluster of 2 worker processes writes the files the CLI's
    batch writes, byte for byte, and names a damaged frame as the CLI does. In a folder whose name
    is Latin-1 bytes, no UTF-8: the summaries name it with U+FFFD alike."""
    import faulthandler

    from distributed import Client, LocalCluster

    import pipetile.dask

    write_sphere_frames(tmp_path, range(1, 6))  # pyopenvdb takes no such path: moved there after
    latin1 = Path(os.fsdecode(os.fsencode(tmp_path) + b"/caf\xe9"))
    latin1.mkdir()
    for frame in tmp_path.glob("seq.*.vdb"):
        frame.rename(latin1 / frame.name)
    tmp_path = latin1
    damaged = tmp_path / "seq.0003.vdb"
    os.truncate(damaged, damaged.stat().st_size // 2)
    (tmp_path / "cli").mkdir()
    (tmp_path / "dask").mkdir()
    pattern = str(tmp_path / "seq.####.vdb")
    cli = subprocess.run([CLI, "mesh", pattern, "-o", tmp_path / "cli/seq.####.ply", "--report",
                          tmp_path / "cli/seq.####.json", "--summary", tmp_path / "summary.json"],
                         capture_output=True, text=True, errors="surrogateescape")
    assert cli.returncode == 1, cli.stderr
    cli_summary = json.loads((tmp_path / "summary.json").read_text())

    faulthandler.dump_traceback_later(240, exit=True)  # a hung cluster fails the test, not CI
    try:
        with LocalCluster(processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            summary = pipetile.dask.mesh_frames(client, pattern, None, str(tmp_path / "dask/seq.$F4.ply"),
                                                report=str(tmp_path / "dask/seq.%04d.json"), timeout=120)
    finally:
        faulthandler.cancel_dump_traceback_later()

    assert (summary["frames"], summary["meshed"], summary["failed"]) == (5, 4, 1)
    assert summary["failures"] == cli_summary["failures"]  # the same frame, the same one-line message
    assert summary["failures"][0]["error"].startswith("frame 3: ")
    assert "caf\ufffd" in summary["failures"][0]["error"] and "caf\ufffd" in summary["input"]
    assert summary["totals"]["triangles"] == cli_summary["totals"]["triangles"]
    meshes = sorted(p.name for p in (tmp_path / "cli").glob("*.ply"))
    assert meshes == sorted(p.name for p in (tmp_path / "dask").iterdir() if p.suffix == ".ply")
    assert len(meshes) == 4 * 4  # 4 frames meshed, 4 levels each
    for name in meshes:
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    # The reports hold the same meshes (their times differ).
    for f in (1, 2, 4, 5):
        cli_report = json.loads((tmp_path / f"cli/seq.{f:04d}.json").read_text())
        dask_report = json.loads((tmp_path / f"dask/seq.{f:04d}.json").read_text())
        assert [lv["triangles"] for lv in dask_report["levels"]] == [lv["triangles"] for lv in cli_report["levels"]]
