"""Exact convex decomposition: convex, exact in volume, no clearance lost; CoACD refused."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from assetgen.checks.module_checks import CheckError
from assetgen.collision.exact import OVERLAP, exact_pieces
from assetgen.collision.pieces import UNION_TOLERANCE, check_pieces, collision_pieces
from assetgen.core.stl import parse_stl_mm, read_stl_triangles_mm, stl_bytes
from assetgen.geometry.solids import build_module, insertion_travel
from assetgen.params.sampler import SamplerConfig, sample_params

from .test_geometry import CORNERS


@pytest.mark.parametrize("seed", [0, 3, 11, 13, 21, 52])
def test_exact_pieces_are_convex_and_without_overlap_add_up_to_the_module(seed):
    g = build_module(sample_params(SamplerConfig(), seed))
    for overlap in (0.0, OVERLAP):
        total = 0.0
        for m in exact_pieces(g, overlap=overlap):
            tm = trimesh.Trimesh(m.vertices, m.faces, process=True)
            assert tm.is_watertight and tm.is_convex
            total += tm.volume
        if overlap == 0.0:  # the cells tile the module
            assert total == pytest.approx(g.module_volume, rel=1e-6)
        else:  # they reach past their seams (tests/test_piece_overlap.py)
            assert total > g.module_volume * 1.01
    pieces = exact_pieces(g)
    # Local pieces: besides the 4 far-plate boxes, each covers well under a quarter of the
    # plate's area, so a broadphase keeps them apart.
    plate = g.params.plate_size**2
    big = [np.prod(np.ptp(m.vertices[:, :2], axis=0)) > plate / 4 for m in pieces]
    assert sum(big) <= 4


@pytest.mark.parametrize("name", list(CORNERS))
def test_corner_pieces_keep_the_clearance(name, tmp_path):
    g = build_module(CORNERS[name])
    _, rec = collision_pieces(g, insertion_travel(g))
    assert rec["volume_ratio"] > 1.0  # the pieces overlap at their seams
    assert rec["overlap_m"] == OVERLAP and rec["outside_module_m"] <= UNION_TOLERANCE
    assert abs(rec["clearance_lower_bound_m"] - g.params.clearance) <= 1e-6
    assert abs(rec["insertion_lower_bound_m"] - g.params.clearance) <= 1e-6


def test_pieces_are_checked_as_the_files_store_them(tmp_path):
    """The pieces the check proved are the float32-millimetre ones the MJCF and USD hold
    (what an STL of each reads back as), each a closed convex solid; no file is written."""
    g = build_module(CORNERS["32-gon"])
    kept, rec = collision_pieces(g, insertion_travel(g))
    assert rec["pieces"] == len(kept) == len(exact_pieces(g))
    assert not list(tmp_path.iterdir())
    for piece, exact in zip(kept, exact_pieces(g), strict=True):
        back = parse_stl_mm(stl_bytes(exact))
        assert np.array_equal(piece.vertices, back.vertices)
        assert np.array_equal(piece.faces, back.faces)
        tm = trimesh.Trimesh(piece.vertices, piece.faces, process=False)
        assert tm.is_watertight and tm.is_convex


def test_piece_that_loses_clearance_is_refused():
    from assetgen.checks.module_checks import fcl_distance, fcl_object

    g = build_module(CORNERS["32-gon"])
    pieces = exact_pieces(g)
    design = g.design_pose.matrix()
    peg = fcl_object(g.peg, design)
    nearest = min(range(len(pieces)), key=lambda i: fcl_distance(peg, fcl_object(pieces[i])))
    # Push the nearest piece 0.1 mm toward the peg's centre: it now eats into the clearance.
    centre = design[:3, 3] + 0.5 * g.params.peg_height * design[:3, 2]
    m = pieces[nearest]
    direction = centre - m.vertices.mean(axis=0)
    pieces[nearest] = type(m)(m.vertices + 1e-4 * direction / np.linalg.norm(direction), m.faces)
    with pytest.raises(CheckError, match=r"lost\s+clearance"):
        check_pieces(pieces, g.peg, g, insertion_travel(g))


def test_coacd_output_is_rechecked_and_refused_when_it_loses_clearance(tmp_path):
    """CoACD's approximate pieces fill part of a 1 mm gap: the module is refused clearly."""
    from assetgen.collision.coacd_pieces import CoacdConfig, coacd_pieces

    g = build_module(CORNERS["shortest peg shallowest hole"])
    pieces = coacd_pieces(g.module, CoacdConfig(threshold=0.2, max_convex_hull=4))
    assert pieces
    with pytest.raises(CheckError, match="decomposition lost"):
        check_pieces(pieces, g.peg, g, insertion_travel(g))


def test_corrupt_collision_file_is_named(tmp_path):
    f = tmp_path / "piece.stl"
    f.write_bytes(b"\0" * 80 + (10).to_bytes(4, "little") + b"\0" * 20)
    with pytest.raises(ValueError, match=r"piece\.stl: header says 10 triangles"):
        read_stl_triangles_mm(f)
