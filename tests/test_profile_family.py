"""The `profile` family: non-convex sections, their exact mitred offset, their exact convex
partition, and modules whose peg sits at exactly its clearance from the plate on every
face (concave corners included), generated and checked as files."""

from __future__ import annotations

import math
from dataclasses import replace

import manifold3d as m3
import numpy as np
import pytest

from assetgen.families import registry
from assetgen.families.profile import SHAPES, ProfileParams, ProfileSampler, build_profile
from assetgen.families.profile import sections as S
from assetgen.geometry.convex_partition import convex_partition
from assetgen.geometry.polygon_offset import OffsetError, centroid, mitred_offset, signed_area
from assetgen.params.module_params import ParamError
from tests.test_profile_bolt import TOL, _axis, gap, pieces_in_module

C = 1e-3


def sections_of_every_kind() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {
        "L": S.l_shape(0.02, 0.4),
        "T": S.t_shape(0.015, 0.35),
        "cross": S.cross_shape(0.02, 0.3),
        "star": S.star(0.02, 6, 0.5),
        "flat": S.keyed_round(0.015, "flat", 0.0, 0.2),
        "keyway": S.keyed_round(0.02, "keyway", 0.2, 0.25),
        "spline": S.spline_shaft(0.02, 8, 0.2),
        "random": S.random_polygon(rng, 0.02, 10, 0.5, math.radians(240)),
    }


def distance_to_polygon(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each point (k, 2) to the polygon's boundary (n, 2), by segment."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.einsum("knd,nd->kn", points[:, None, :] - a[None], ab) / np.einsum("nd,nd->n", ab, ab)
    near = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - near, axis=2).min(axis=1)


def area(pieces: list[np.ndarray]) -> float:
    """The area (m^2) of the union of polygons (manifold3d's 2D booleans, in micrometres:
    Clipper2 rounds coordinates to a fixed number of decimals)."""
    return m3.CrossSection([p * 1e6 for p in pieces], m3.FillRule.NonZero).area() * 1e-12


@pytest.mark.parametrize("name", list(sections_of_every_kind()))
def test_the_offset_is_the_clearance_on_every_face_and_never_less(name) -> None:
    poly = sections_of_every_kind()[name]
    out = mitred_offset(poly, C)
    # every point of the offset boundary is at least C from the section, and each moved
    # edge's middle exactly C (from its own edge)
    t = np.linspace(0, 1, 41)[:, None, None]
    boundary = (out[None] + t * (np.roll(out, -1, axis=0) - out)[None]).reshape(-1, 2)
    assert distance_to_polygon(boundary, poly).min() >= C - 1e-12
    mids = 0.5 * (out + np.roll(out, -1, axis=0))
    np.testing.assert_allclose(distance_to_polygon(mids, poly), C, atol=1e-12)
    assert signed_area(out) > signed_area(poly)


def test_a_slot_narrower_than_twice_the_clearance_is_refused_by_edge() -> None:
    keyway = S.keyed_round(0.02, "keyway", 0.05, 0.3)  # a 2 mm slot
    assert mitred_offset(keyway, 0.9e-3) is not None
    with pytest.raises(OffsetError, match="narrower than twice the clearance"):
        mitred_offset(keyway, 1.1e-3)


@pytest.mark.parametrize("name", list(sections_of_every_kind()))
def test_the_convex_pieces_are_the_section_exactly(name) -> None:
    poly = sections_of_every_kind()[name]
    tiles = convex_partition(poly)
    for piece in tiles + convex_partition(poly, overlap=True):
        u = np.roll(piece, -1, axis=0) - piece
        v = np.roll(u, -1, axis=0)
        assert (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] > 0).all(), "a piece is not convex"
    # the tiles do not overlap (their areas add up) and make up the section
    assert sum(signed_area(p) for p in tiles) == pytest.approx(signed_area(poly), rel=1e-12)
    assert area(tiles) == pytest.approx(signed_area(poly), rel=1e-9)
    grown = convex_partition(poly, overlap=True)
    assert area(grown) == pytest.approx(signed_area(poly), rel=1e-9)  # still the section
    if len(tiles) > 1:
        assert sum(signed_area(p) for p in grown) > signed_area(poly)  # and they overlap
    if name == "flat":
        assert len(tiles) == 1  # a convex section stays one piece


@pytest.mark.parametrize("shape", SHAPES)
def test_every_shape_sits_at_exactly_its_clearance_and_goes_straight_in(shape) -> None:
    params = ProfileSampler(shapes=(shape,)).sample(5)
    asm = build_profile(params)
    (step,) = asm.steps
    peg = [m.vertices for m in pieces_in_module(asm.parts[0])]
    base = [m.vertices for m in pieces_in_module(asm.base)]
    assert gap(peg, base) == pytest.approx(params.clearance, abs=TOL)
    swept = [np.vstack([v, v + step.travel * _axis(step)]) for v in peg]
    assert gap(swept, base) >= params.clearance - TOL


def test_a_concave_corner_is_exact_too() -> None:
    """An L's inner corner: the peg's corner point and the hole's are sqrt(2) C apart
    diagonally, and both walls meeting there are C from the peg's."""
    p = replace(
        ProfileSampler(shapes=("L",)).sample(0),
        hole_tilt_x=0.0, hole_tilt_y=0.0, hole_yaw=0.0, hole_x=0.0, hole_y=0.0,
    )  # fmt: skip
    poly = p.polygon()
    inner = 3  # l_shape's fourth vertex is its concave corner
    out = mitred_offset(poly, p.clearance)
    assert np.linalg.norm(out[inner] - poly[inner]) == pytest.approx(math.sqrt(2) * C, abs=1e-15)
    asm = build_profile(p)
    peg = [m.vertices for m in pieces_in_module(asm.parts[0])]
    base = [m.vertices for m in pieces_in_module(asm.base)]
    assert gap(peg, base) == pytest.approx(C, abs=TOL)


def test_parameters_round_trip_and_bad_ones_are_named() -> None:
    p = ProfileSampler().sample(11)
    assert ProfileParams.from_json(p.to_json()) == p
    with pytest.raises(ParamError, match="counter-clockwise"):
        replace(p, section=tuple(reversed(p.section))).validate()
    with pytest.raises(ParamError, match="shape = 'hexagon'"):
        replace(p, shape="hexagon").validate()
    with pytest.raises(ParamError, match="peg_height"):
        replace(p, peg_height=0.5).validate()
    slot = S.keyed_round(0.02, "keyway", 0.1, 0.3)  # a 4 mm keyway
    slot = tuple(map(tuple, slot - centroid(slot)))
    keyed = replace(p, shape="keyed", section=slot).validate()
    with pytest.raises(ParamError, match="narrower than twice the clearance"):
        replace(keyed, clearance=0.0021).validate()
    with pytest.raises(ParamError, match="clearance"):
        ProfileSampler(clearance=0.003).validate()
    with pytest.raises(ParamError, match="shapes"):
        ProfileSampler(shapes=("circle",)).validate()


def test_a_dataset_of_every_shape_is_written_and_passes_its_checks(tmp_path) -> None:
    from assetgen.dataset.check import check_dataset
    from assetgen.dataset.generate import generate
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetSpec

    sampler = ProfileSampler().validate()
    seen, n = set(), 0
    while seen != set(SHAPES):  # the fewest first seeds that hold every shape
        seen.add(sampler.sample(n).shape)
        n += 1
    assert n <= 20
    spec = DatasetSpec("profile", 0, n, sampler, family="profile")
    s = generate(tmp_path / "p", spec, workers=1, progress=False)
    assert s.generated == n and not s.failures
    assert s.clearance_min_m == pytest.approx(C, abs=1e-8)  # measured on the files (fcl)
    ds = Dataset(tmp_path / "p")
    assert {ds.module_json(mid)["params"]["shape"] for mid in ds.ids} == set(SHAPES)
    assert check_dataset(tmp_path / "p").ok


def test_it_is_a_registered_assembly_family() -> None:
    assert registry.get("profile").layout.name == "assembly"
    assert registry.is_assembly("profile")


@pytest.mark.parametrize("seed", [2245, 2774])
def test_pieces_sharing_a_corner_print_as_one_closed_body(seed) -> None:
    """The hole's pieces (and the peg's) enumerate a shared corner from different planes,
    1e-17 m apart: unless part_mesh snaps them together, these plates and pegs came out
    pinched there, open once stored as float32 STL (9 of the test split's 1024)."""
    from assetgen.checks.module_checks import topology
    from assetgen.core.stl import parse_stl_mm, stl_bytes
    from assetgen.families.part_mesh import part_mesh

    asm = build_profile(ProfileSampler().sample(seed))
    for part in (asm.base, *asm.parts):
        t = topology(parse_stl_mm(stl_bytes(part_mesh(part)), f"{part.name}.stl"))
        assert t["watertight"] and t["winding_consistent"] and t["bodies"] == 1, part.name


@pytest.mark.parametrize("seed", [102069, 103669])
def test_a_crossing_computed_twice_prints_closed(seed) -> None:
    """Two of 10,000 splined plates: manifold3d computes one crossing of the hole's pieces on
    its floor twice, two vertices at one point joined by a fin of no area. The float32 STL
    made them one point and the fin's edge bounded four triangles; part_mesh welds them."""
    from assetgen.checks.module_checks import topology
    from assetgen.core.stl import parse_stl_mm, stl_bytes
    from assetgen.families.part_mesh import part_mesh, weld

    base = build_profile(ProfileSampler().sample(seed)).base
    mesh = part_mesh(base)
    assert len(np.unique(mesh.vertices, axis=0)) == len(mesh.vertices)
    t = topology(parse_stl_mm(stl_bytes(mesh), "base.stl"))
    assert t["watertight"] and t["winding_consistent"] and t["bodies"] == 1
    assert weld(mesh) is mesh  # a mesh without repeated positions comes back as it is
