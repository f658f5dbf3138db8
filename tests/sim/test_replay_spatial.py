"""The replay of spatial robots (free-flyer root) with the URDF's own meshes."""

from __future__ import annotations

import base64
import io
import re
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import trimesh
from synthetic_spatial import (
    DATA,
    Satellite,
    free_flyer,
    panda,
    synthetic_spatial_result,
)

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat.visualizer
    import umsgpack

from ffsm_pin.sim.meshes import ReplayWarning, resolve_mesh
from ffsm_pin.sim.replay import close_visualizer, serve_replay, write_replay_html
from ffsm_pin.sim.scene import BASE_BOX

_COMMAND = re.compile(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)')
ROBOT = "/meshcat/ffsm/robot"


def commands(html: str) -> list[dict]:
    return [umsgpack.unpackb(base64.b64decode(b)) for b in _COMMAND.findall(html)]


def objects(cmds) -> dict[str, dict]:
    return {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}


def clips(cmds) -> dict[str, dict[str, list]]:
    """Animation tracks per node: {path: {".position": [...], ".quaternion": [...]}}."""
    anim = next(c for c in cmds if c["type"] == "set_animation")
    return {
        a["path"]: {t["name"]: [k["value"] for k in t["keys"]] for t in a["clip"]["tracks"]}
        for a in anim["animations"]
    }


def key_times(cmds, path: str) -> np.ndarray:
    """Times [s] of a node's animation keys."""
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"] == path)
    keys = next(t["keys"] for t in clip["tracks"] if t["name"] == ".position")
    return np.array([k["time"] for k in keys]) / clip["fps"]


def array(ext: umsgpack.Ext) -> np.ndarray:
    """A typed array as meshcat packs it (three.js type codes, see meshcat.geometry)."""
    dtype = {0x12: np.uint8, 0x15: np.int32, 0x16: np.uint32, 0x17: np.float32}[ext.type]
    return np.frombuffer(ext.data, dtype=dtype)


def rotation_xyzw(quat) -> np.ndarray:
    x, y, z, w = quat  # three.js order
    return pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()


def assert_pose(tracks: dict, k: int, expected: np.ndarray) -> None:
    """Frame k of a node's animation is the 4x4 placement ``expected``."""
    assert np.allclose(tracks[".position"][k], expected[:3, 3], atol=1e-5)
    assert np.allclose(rotation_xyzw(tracks[".quaternion"][k]), expected[:3, :3], atol=1e-5)


@pytest.fixture(scope="module")
def arm():
    return panda()


@pytest.fixture(scope="module")
def panda_html(arm, tmp_path_factory):
    result = synthetic_spatial_result(arm, "panda_hand_tcp", duration=2.0, dt=1e-2)
    path = tmp_path_factory.mktemp("panda") / "replay.html"
    with warnings.catch_warnings():
        warnings.simplefilter("error", ReplayWarning)  # every Panda mesh is found
        write_replay_html(arm, result, path, fps=10)
    return result, path.read_text(encoding="utf-8")


def test_panda_scene_has_one_embedded_mesh_per_visual(arm, panda_html):
    _, html = panda_html
    # Pinocchio's own visual model of the file, meshes found through the package folder
    visuals = pin.buildGeomFromUrdf(
        arm.model, str(arm.urdf_path), pin.GeometryType.VISUAL, package_dirs=[*arm.package_dirs]
    )
    assert visuals.ngeoms == 11  # link0..7, hand, two fingers
    drawn = {p: o for p, o in objects(commands(html)).items() if p.startswith(ROBOT + "/")}
    assert set(drawn) == {f"{ROBOT}/{g.name}" for g in visuals.geometryObjects}
    for g in visuals.geometryObjects:
        obj = drawn[f"{ROBOT}/{g.name}"]["object"]
        assert obj["type"] == "_meshfile_object" and obj["format"] == "dae"
        # the file's bytes, unchanged, in the page
        assert obj["data"] == Path(g.meshPath).read_text(encoding="utf-8")
        assert len(obj["data"]) > 10_000
    # self-contained: nothing fetched but data: URLs, no external script
    assert not re.search(r"<script[^>]*\bsrc\s*=", html, re.I)
    assert set(re.findall(r'fetch\("([a-z]+):', html)) == {"data"}
    assert 5e6 < len(html) < 30e6  # the meshes are embedded, within the size budget


def test_panda_frames_are_pinocchio_placements(arm, panda_html):
    result, html = panda_html
    cmds = commands(html)
    tracks = clips(cmds)
    model, data = arm.model, arm.model.createData()
    visuals = pin.buildGeomFromUrdf(
        model, str(arm.urdf_path), pin.GeometryType.VISUAL, package_dirs=[*arm.package_dirs]
    )
    gdata = pin.GeometryData(visuals)
    for k, i in [(0, 0), (7, 70), (20, 200)]:  # 10 fps, dt 0.01 s
        pin.forwardKinematics(model, data, result["q"][i])
        pin.updateGeometryPlacements(model, data, visuals, gdata)
        for g, placement in zip(visuals.geometryObjects, gdata.oMg, strict=True):
            assert_pose(tracks[f"{ROBOT}/{g.name}"], k, placement.homogeneous)
    # the still picture before playing is frame 0
    still = {c["path"]: c["matrix"] for c in cmds if c["type"] == "set_transform"}
    pin.forwardKinematics(model, data, result["q"][0])
    pin.updateGeometryPlacements(model, data, visuals, gdata)
    for g, placement in zip(visuals.geometryObjects, gdata.oMg, strict=True):
        matrix = np.array(still[f"{ROBOT}/{g.name}"]).reshape(4, 4).T  # column-major
        assert np.allclose(matrix, placement.homogeneous, atol=1e-6)


def test_paths_and_centring_are_three_dimensional(panda_html):
    result, html = panda_html
    cmds = commands(html)
    objs = objects(cmds)

    def line_points(path):
        geom = objs[path]["geometries"][0]
        return array(geom["data"]["attributes"]["position"]["array"]).reshape(-1, 3)

    # float32 in the page: 1e-6 relative
    ref, ee = result["z_e_d"][:, :3], result["z_e"][:, :3]
    assert np.allclose(line_points("/meshcat/ffsm/reference/path"), ref, rtol=1e-6, atol=1e-7)
    assert np.allclose(line_points("/meshcat/ffsm/ee_path"), ee, rtol=1e-6, atol=1e-7)
    target = clips(cmds)["/meshcat/ffsm/reference/target"][".position"]
    assert np.allclose(target[15], result["z_e_d"][150, :3])
    # the centre of the scene's box (the paths, every link in every frame) is moved to the
    # origin: all of it in view of the camera, which orbits about the origin
    shift = next(
        np.array(c["matrix"]).reshape(4, 4).T
        for c in cmds
        if c["type"] == "set_transform" and c["path"] == "/meshcat/ffsm"
    )
    tracks = clips(cmds)
    links = [np.array(v[".position"]) for p, v in tracks.items() if p.startswith(ROBOT)]
    pts = np.concatenate([ref, ee, *links])
    assert np.allclose(shift[:3, 3], -0.5 * (pts.min(axis=0) + pts.max(axis=0)), atol=1e-6)
    # the camera looks at the origin from a distance that frames that box
    camera = next(
        c["value"] for c in cmds if c["type"] == "set_property" and c["path"].startswith("/Cam")
    )
    size = np.ptp(pts, axis=0).max()
    assert size < np.linalg.norm(camera) < 2.0 * size + 1.0


def test_missing_mesh_warns_once_and_the_rest_is_drawn(tmp_path):
    robot = free_flyer(DATA / "mesh_arm.urdf", package_dirs=(DATA,))
    result = synthetic_spatial_result(robot, "tool", duration=1.0, dt=0.05)
    with pytest.warns(ReplayWarning) as record:
        html = write_replay_html(robot, result, tmp_path / "r.html").read_text()
    messages = [str(w.message) for w in record if issubclass(w.category, ReplayWarning)]
    assert len(messages) == 1 and "package://mesh_pkg/meshes/nowhere.stl" in messages[0]
    assert "'upper'" in messages[0]  # names the link

    objs = objects(commands(html))
    stl = objs[f"{ROBOT}/upper_0"]
    geom = stl["geometries"][0]
    assert geom["type"] in ("_meshfile", "_meshfile_geometry") and geom["format"] == "stl"
    assert geom["data"].data == (DATA / "mesh_pkg/meshes/block.stl").read_bytes()
    # URDF scale="3 1 0.5" in the object's own matrix (three.js reads it column-major)
    matrix = np.array(stl["object"]["matrix"]).reshape(4, 4).T
    assert np.allclose(matrix, np.diag([3.0, 1.0, 0.5, 1.0]))
    color = stl["materials"][0]["color"]  # the URDF's rgba 0.1 0.2 0.9, to 8 bits
    rgb = np.array([(color >> 16) & 255, (color >> 8) & 255, color & 255]) / 255
    assert np.allclose(rgb, [0.1, 0.2, 0.9], atol=1 / 255)

    obj = objs[f"{ROBOT}/fore_0"]["geometries"][0]
    assert obj["format"] == "obj"
    assert obj["data"] == (DATA / "mesh_pkg/meshes/rod.obj").read_text()
    assert np.allclose(objs[f"{ROBOT}/fore_0"]["object"]["matrix"], np.diag([2.0, 2, 2, 1]).ravel())
    assert objs[f"{ROBOT}/fore_1"]["geometries"][0]["type"] == "SphereGeometry"
    # URDF cylinders run along z, three.js ones along y: the object's matrix turns y onto z
    cyl = objs[f"{ROBOT}/fore_2"]
    assert cyl["geometries"][0]["type"] == "CylinderGeometry"
    own = np.array(cyl["object"]["matrix"]).reshape(4, 4).T
    assert np.allclose(own[:3, :3] @ [0, 1, 0], [0, 0, 1]) and np.allclose(own[:3, 3], 0)
    # a Collada file with a URDF colour: its triangles in the URDF's material
    dae = objs[f"{ROBOT}/fore_3"]
    assert dae["geometries"][0]["format"] == "dae"
    assert dae["geometries"][0]["data"] == (DATA / "mesh_pkg/meshes/cap.dae").read_text()
    assert np.allclose(np.reshape(dae["object"]["matrix"], (4, 4)), np.diag([1.0, 2, 0.5, 1]))
    color = dae["materials"][0]["color"]
    rgb = np.array([(color >> 16) & 255, (color >> 8) & 255, color & 255]) / 255
    assert np.allclose(rgb, [0.1, 0.8, 0.2], atol=1 / 255)
    assert dae["materials"][0]["opacity"] == pytest.approx(0.5)
    assert not any("nowhere" in p for p in objs)


def test_root_without_visuals_gets_a_box(tmp_path):
    """The satellite link has no visual: a box of the satellite's size centred on it, or of
    base_size with its top face through the root's origin (the arm stands on it)."""
    bare = free_flyer(DATA / "mesh_arm.urdf", package_dirs=(DATA,))
    sized = free_flyer(DATA / "mesh_arm.urdf", package_dirs=(DATA,), satellite=Satellite((1, 2, 3)))
    result = synthetic_spatial_result(bare, "tool", duration=1.0, dt=0.05)
    data = bare.model.createData()
    cases = [
        (sized, {}, [1, 2, 3], 0.0),
        (bare, {}, [0.5] * 3, -0.25),
        (bare, {"base_size": (0.7, 0.8, 0.9)}, [0.7, 0.8, 0.9], -0.45),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReplayWarning)
        for robot, kw, size, below in cases:
            cmds = commands(write_replay_html(robot, result, tmp_path / "r.html", **kw).read_text())
            box = objects(cmds)[f"{ROBOT}/{BASE_BOX}"]["geometries"][0]
            assert box["type"] == "BoxGeometry"
            assert np.allclose([box["width"], box["height"], box["depth"]], size)
            tracks = clips(cmds)[f"{ROBOT}/{BASE_BOX}"]
            # 30 fps, samples every 0.05 s: one key per sample, at the sample's time
            assert np.allclose(key_times(cmds, f"{ROBOT}/{BASE_BOX}"), result["t"], atol=0.5 / 30)
            for k in (0, 10, 20):
                pin.forwardKinematics(bare.model, data, result["q"][k])
                offset = pin.SE3(np.eye(3), np.array([0.0, 0.0, below]))
                assert_pose(tracks, k, (data.oMi[1] * offset).homogeneous)


def test_panda_root_link_has_its_own_visual_so_no_box(panda_html):
    _, html = panda_html
    assert f"{ROBOT}/{BASE_BOX}" not in objects(commands(html))


def test_mesh_paths_are_resolved(tmp_path):
    base = DATA
    block = (DATA / "mesh_pkg/meshes/block.stl").resolve()
    assert resolve_mesh("mesh_pkg/meshes/block.stl", base, []) == block  # relative
    assert resolve_mesh("package://mesh_pkg/meshes/block.stl", None, [DATA]) == block
    assert resolve_mesh(f"file://{block}", None, []) == block
    assert resolve_mesh(str(block), None, []) == block
    # package:// found by searching upwards from the URDF's folder, as yourdfpy does
    assert resolve_mesh("package://data/mesh_pkg/meshes/block.stl", DATA / "mesh_pkg", []) == block
    assert resolve_mesh("package://mesh_pkg/meshes/nowhere.stl", base, [DATA]) is None
    assert resolve_mesh("mesh_pkg/meshes/block.stl", None, []) is None  # relative to nothing


def test_write_html_starts_no_server(tmp_path, monkeypatch, arm):
    def refuse(*args, **kwargs):
        raise AssertionError("write_replay_html must not start a meshcat server")

    monkeypatch.setattr(meshcat.visualizer, "start_zmq_server_as_subprocess", refuse)
    result = synthetic_spatial_result(arm, "panda_hand_tcp", duration=0.2, dt=0.1)
    assert write_replay_html(arm, result, tmp_path / "r.html").is_file()


def test_live_server_gets_the_meshes(arm):
    """--meshcat: the same scene (DAE meshes included) reaches meshcat's own server."""
    result = synthetic_spatial_result(arm, "panda_hand_tcp", duration=0.5, dt=0.05)
    vis = serve_replay(arm, result)
    proc = vis.window.server_proc
    try:
        assert proc.poll() is None
        served = objects(commands(vis.static_html()))  # the server's own copy of the scene
    finally:
        close_visualizer(vis)
    assert proc.poll() is not None  # no stray server process
    visuals = pin.buildGeomFromUrdf(
        arm.model, str(arm.urdf_path), pin.GeometryType.VISUAL, package_dirs=[*arm.package_dirs]
    )
    for g in visuals.geometryObjects:
        obj = served[f"{ROBOT}/{g.name}"]["object"]
        assert obj["data"] == Path(g.meshPath).read_text(encoding="utf-8")


def test_meshes_beyond_the_size_budget_go_in_as_binary_stl(arm, panda_html, tmp_path):
    result, full_html = panda_html
    with pytest.warns(ReplayWarning, match=r"meshes take 10\.\d MB \(more than 1 MB\)"):
        path = write_replay_html(arm, result, tmp_path / "small.html", fps=10, max_mesh_mb=1)
    html = path.read_text(encoding="utf-8")
    assert len(html) < 0.75 * len(full_html)
    objs = objects(commands(html))
    visuals = pin.buildGeomFromUrdf(
        arm.model, str(arm.urdf_path), pin.GeometryType.VISUAL, package_dirs=[*arm.package_dirs]
    )
    for g in visuals.geometryObjects:
        obj = objs[f"{ROBOT}/{g.name}"]
        geom = obj["geometries"][0]
        assert geom["format"] == "stl"
        stl = trimesh.load(io.BytesIO(geom["data"].data), file_type="stl")
        # same size, place and orientation as Panda's collision mesh of that link (a hull
        # of the visual mesh, drawn by Pinocchio's own loader from an independent file)
        hull = trimesh.load(g.meshPath.replace("/visual/", "/collision/").replace(".dae", ".stl"))
        assert np.allclose(stl.bounds, hull.bounds, atol=0.02), g.name
        # one colour, the surface-weighted mean of the file's materials: Panda is white and
        # light grey, brighter than the grey (0.6, 0.6, 0.65) used when no colour is known
        color = obj["materials"][0]["color"]
        rgb = np.array([(color >> 16) & 255, (color >> 8) & 255, color & 255]) / 255
        assert rgb.min() > 0.68, g.name


def test_collada_with_a_missing_texture_is_drawn_in_one_colour(tmp_path):
    """A texture the DAE file names but nobody has: a warning, the triangles still drawn."""
    meshes = tmp_path / "mesh_pkg" / "meshes"
    meshes.mkdir(parents=True)
    dae = (DATA / "mesh_pkg/meshes/cap.dae").read_text()
    images = '<library_images><image id="skin"><init_from>skin.png</init_from></image>'
    (meshes / "cap.dae").write_text(
        dae.replace("<library_effects>", images + "</library_images><library_effects>", 1)
    )
    urdf = (DATA / "mesh_arm.urdf").read_text()
    urdf = urdf.replace('<material name="green"><color rgba="0.1 0.8 0.2 0.5"/></material>', "")
    for name in ("block.stl", "rod.obj"):
        (meshes / name).write_bytes((DATA / "mesh_pkg/meshes" / name).read_bytes())
    (tmp_path / "arm.urdf").write_text(urdf)
    robot = free_flyer(tmp_path / "arm.urdf", package_dirs=(tmp_path,))
    result = synthetic_spatial_result(robot, "tool", duration=0.2, dt=0.1)
    with pytest.warns(ReplayWarning) as record:
        html = write_replay_html(robot, result, tmp_path / "r.html").read_text()
    texture = [str(w.message) for w in record if "skin.png" in str(w.message)]
    assert len(texture) == 1 and "'fore_3'" in texture[0]
    geom = objects(commands(html))[f"{ROBOT}/fore_3"]["geometries"][0]
    assert geom["format"] == "dae" and "skin.png" in geom["data"]
