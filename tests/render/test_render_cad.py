"""CAD meshes of logs and assemblies: watertight, right size, slots at the notches."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from strategies import build_random_structure
from unseeable.domain import Extent, GridPose, Log, LogGeometry, Structure
from unseeable.errors import InputError
from unseeable.render.cad import (
    export_mesh,
    log_mesh,
    log_surfaces,
    log_to_grid,
    structure_mesh,
)

G = LogGeometry()


def _section_height(mesh: trimesh.Trimesh, x: float) -> tuple[float, float]:
    """y range of the mesh's cross-section by the plane at ``x`` (log frame)."""
    sec = mesh.section(plane_origin=[x, 0.0, 0.0], plane_normal=[1.0, 0.0, 0.0])
    return float(sec.bounds[0, 1]), float(sec.bounds[1, 1])


@pytest.mark.parametrize("notches", [1, 2, 3])
def test_log_is_watertight_with_the_right_length(notches):
    mesh = log_mesh(notches)
    assert mesh.is_watertight and mesh.is_volume
    assert mesh.extents[0] == pytest.approx((notches - 1) * G.l1 + 2 * G.l3, abs=1e-6)
    assert mesh.extents[1] == pytest.approx(G.l2, abs=1e-6)
    assert mesh.extents[2] == pytest.approx(G.l2, rel=1e-3)
    assert mesh.bounds[0, 0] == pytest.approx(-G.l3)


@pytest.mark.parametrize("notches", [1, 2, 3])
def test_slots_top_and_bottom_at_every_notch_only(notches):
    mesh = log_mesh(notches)
    r, depth = G.radius, G.notch_depth
    for n in range(notches):
        centre = n * G.l1
        # Inside the slot (l2 wide) the log is l2/4 thinner on top and below.
        for x in (centre, centre + 0.45 * G.l2, centre - 0.45 * G.l2):
            lo, hi = _section_height(mesh, x)
            assert hi == pytest.approx(r - depth, abs=1e-6)
            assert lo == pytest.approx(-r + depth, abs=1e-6)
        # Just outside the slot the log is whole.
        for x in (centre + 0.55 * G.l2, centre - 0.55 * G.l2):
            lo, hi = _section_height(mesh, x)
            assert hi == pytest.approx(r, rel=1e-3) and lo == pytest.approx(-r, rel=1e-3)
    # Between notches, no slot.
    if notches > 1:
        lo, hi = _section_height(mesh, G.l1 / 2)
        assert hi - lo == pytest.approx(G.l2, rel=1e-3)
    # Volume: the cylinder less two slots per notch (circular segments above r - l2/4).
    seg = r**2 * np.arccos((r - depth) / r) - (r - depth) * np.sqrt(r**2 - (r - depth) ** 2)
    expected = np.pi * r**2 * G.log_length(notches) - 2 * notches * seg * G.l2
    assert mesh.volume == pytest.approx(expected, rel=0.01)


def test_crossing_logs_interlock_without_overlap():
    # A layer-0 log and a layer-1 log crossing at notch (0, 0): they touch at the slot floors.
    s = Structure(Extent(1, 2, 1), [Log(0, (0, 0), 1), Log(1, (0, 0), 1)])
    a = log_mesh(1).apply_transform(log_to_grid(s.logs[0]))
    b = log_mesh(1).apply_transform(log_to_grid(s.logs[1]))
    assert a.bounds[1, 1] == pytest.approx(G.l2, abs=1e-6)  # top of the lower log: r + r
    assert b.bounds[0, 1] == pytest.approx(G.layer_height(1) - G.radius)
    # Where they cross, the lower log's slot floor meets the upper log's slot floor.
    lo_a, hi_a = _section_height(log_mesh(1), 0.0)
    assert G.layer_height(0) + hi_a == pytest.approx(G.layer_height(1) - G.radius + G.notch_depth)
    # Odd layers run along z.
    assert b.extents[2] == pytest.approx(G.log_length(1)) and b.extents[0] < G.l2 + 1e-6


def test_bad_notch_count_is_an_input_error():
    with pytest.raises(InputError):
        log_mesh(4)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), yaw=st.sampled_from([0.0, 30.0, 90.0]))
def test_structure_mesh_places_every_log_at_its_pose(seed, yaw):
    s = build_random_structure(Extent(3, 3, 3), seed, 0.8)
    pose = GridPose(120.0, -40.0, yaw)
    mesh = structure_mesh(s, pose, segments=16, fuse=False)
    owner = mesh.metadata["log_of_face"]
    assert len(owner) == len(mesh.faces)
    if not s.logs:
        return
    assert mesh.is_watertight
    fused = structure_mesh(s, pose, segments=16)
    assert fused.is_watertight and fused.is_volume
    assert set(fused.metadata["log_of_face"].tolist()) == set(range(len(s.logs)))
    # Touching logs share no volume: the union's volume is the sum of the logs'.
    assert fused.volume == pytest.approx(mesh.volume, rel=1e-6)
    for n, log in enumerate(s.logs):
        verts = mesh.vertices[np.unique(mesh.faces[owner == n])]
        grid = pose.world_to_grid(verts)
        centre = (grid.min(axis=0) + grid.max(axis=0)) / 2
        axis = 0 if log.layer % 2 == 0 else 2
        first = np.array([log.at[0] * G.l1, G.layer_height(log.layer), log.at[1] * G.l1])
        expect = first.copy()
        expect[axis] += (log.notches - 1) * G.l1 / 2
        np.testing.assert_allclose(centre, expect, atol=1e-3)
        assert grid[:, 1].min() == pytest.approx(G.layer_height(log.layer) - G.radius, abs=1e-6)


@pytest.mark.parametrize("suffix", [".stl", ".ply", ".obj"])
def test_export_round_trips(tmp_path, suffix):
    mesh = log_mesh(2, segments=16)
    path = tmp_path / f"log{suffix}"
    export_mesh(mesh, path)
    back = trimesh.load(path, force="mesh")
    assert back.volume == pytest.approx(mesh.volume, rel=1e-4)


def test_export_rejects_unknown_suffix(tmp_path):
    with pytest.raises(InputError, match="unknown mesh format"):
        export_mesh(log_mesh(1), tmp_path / "log.xyz")
    assert not list(tmp_path.iterdir())


def test_render_surfaces_cover_the_mesh_with_unit_normals():
    side, ends = log_surfaces(3)
    total = log_mesh(3).area
    area = 0.0
    for surf in (side, ends):
        tri = surf.vertices[surf.faces]
        area += 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                     axis=1).sum()
        np.testing.assert_allclose(np.linalg.norm(surf.normals, axis=1), 1.0, atol=1e-5)
    assert area == pytest.approx(total, rel=1e-4)
    # End grain faces are those facing along the axis (end discs and slot walls).
    tri = ends.vertices[ends.faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.abs(normal[:, 0]) > 0.9 * np.linalg.norm(normal, axis=1))
