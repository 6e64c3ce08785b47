"""Tests of the link capsules (bracekit.model.geometry) and the link clearance (bracekit.kinematics.clearance).

References: capsules read off the URDF text by hand, the plane distance of end points placed by an independent
Pinocchio model, a brute-force clearance from 2001 points sampled along each capsule segment (their distance
from the solid computed here from the nearest point of the top, rim circle or side; the disk's edge found by
bisection for penetration), and central finite differences of the clearance.
"""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pinocchio as pin
import pytest

from bracekit.contact import Brace, Surface
from bracekit.errors import InputError, ModelError
from bracekit.kinematics import BracedRobot
from bracekit.kinematics.clearance import CACHE_SIZE, Clearance, link_clearance, link_clearance_gradient
from bracekit.model.geometry import DEFAULT_LINK_RADIUS
from bracekit.model.robot import Robot
from bracekit.model.shipped import load_model
from bracekit.objective import central_difference
from helpers import random_chain_urdf


def same_least(clearance: Clearance, qs: list[np.ndarray], values: np.ndarray, joints: np.ndarray) -> None:
    """The least clearances of a path against minimum at each configuration: 1e-12 m, and the same link.

    Another link only where two links tie to rounding (two capsules meeting at the lowest point, a joint's
    origin): its own clearance is then the least to 1e-12 m.
    """
    one = [clearance.minimum(q) for q in qs]
    np.testing.assert_allclose(values, [v for v, _ in one], rtol=0.0, atol=1e-12)
    for q, joint, (value, link) in zip(qs, joints.tolist(), one, strict=True):
        if joint != link:
            assert abs({d.joint: d.clearance for d in clearance.links(q, False)}[joint] - value) <= 1e-12


def _with_collisions(text: str) -> str:
    """The random chain with a cylinder on l1, a sphere on l2, a box on l3 (l4.. keep defaults).

    Primitives only: such a robot keeps the capsules (a URDF with a mesh gets coal's clearance,
    tests/geometry/).
    """
    geometry = {
        "l1": '<collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>'
        '<geometry><cylinder radius="0.03" length="0.2"/></geometry></collision>',
        "l2": '<collision><origin xyz="0 0.05 0"/><geometry><sphere radius="0.06"/></geometry></collision>',
        "l3": '<collision><geometry><box size="0.02 0.3 0.04"/></geometry></collision>',
    }
    for link, xml in geometry.items():
        text = text.replace(f'<link name="{link}"><inertial>', f'<link name="{link}">{xml}<inertial>')
    return text


def test_capsules_come_from_cylinders_spheres_boxes_and_default_for_bare_links() -> None:
    robot = Robot.from_urdf(_with_collisions(random_chain_urdf(5, seed=3)), tip="tip")
    caps = {c.link: c for c in robot.link_capsules()}
    cyl = caps["l1"]  # along the x axis of l1 (z turned by +90° about y), centred at x = 0.1
    np.testing.assert_allclose(sorted([cyl.a[0], cyl.b[0]]), [0.0, 0.2], atol=1e-12)
    np.testing.assert_allclose([cyl.a[1:], cyl.b[1:]], 0.0, atol=1e-12)
    assert cyl.radius == 0.03
    sphere = caps["l2"]
    np.testing.assert_allclose([sphere.a, sphere.b], [[0, 0.05, 0]] * 2, atol=1e-12)
    assert sphere.radius == 0.06
    box = caps["l3"]  # the bounding capsule along the 0.3 m edge, radius the half-diagonal of 0.02 × 0.04
    np.testing.assert_allclose([box.a, box.b], [[0, -0.15, 0], [0, 0.15, 0]], atol=1e-12)
    assert box.radius == pytest.approx(np.hypot(0.01, 0.02))
    default = caps["j4"]  # no collision element: the default capsule from joint 4 to joint 5
    np.testing.assert_allclose(default.b, robot.model.jointPlacements[5].translation)
    assert default.radius == DEFAULT_LINK_RADIUS
    np.testing.assert_allclose(caps["j5"].b, [0.1, 0.02, 0.03])  # the last joint's default capsule ends at the tip
    assert len(robot.with_stiffness(100.0).link_capsules(0.01)) == 5


def test_the_paper_robot_has_default_capsules_and_bad_inputs_are_refused() -> None:
    robot = load_model("paper-robot")
    assert robot.collisions == ()
    assert {c.radius for c in robot.link_capsules()} == {DEFAULT_LINK_RADIUS}
    with pytest.raises(InputError, match="link_radius"):
        robot.link_capsules(-1.0)
    bad = _with_collisions(random_chain_urdf(5, seed=3)).replace('radius="0.06"', 'radius="wide"')
    with pytest.raises(ModelError, match="collision"):
        Robot.from_urdf(bad, tip="tip")


def _braced(region: float | None, centre: tuple[float, float] = (0.0, 0.0)) -> BracedRobot:
    text = random_chain_urdf(6, seed=11, brace_link=3)
    robot = Robot.from_urdf(_with_collisions(text), tip="tip")
    return BracedRobot(robot, Brace("brace", Surface([*centre, -0.2], [0.0, 0.0, 1.0]), region_radius=region))


@pytest.mark.parametrize("seed", range(5))
def test_clearance_is_the_lowest_capsule_end_over_the_plane_and_its_gradient_matches_finite_differences(seed) -> None:
    braced = _braced(None)
    q = np.random.default_rng(seed).uniform(-2.0, 2.0, braced.n)
    state = braced.state(q)
    value, link = link_clearance(state)
    model, data = braced.robot.model, braced.robot.model.createData()
    pin.forwardKinematics(model, data, q)
    skip = model.frames[braced.brace_id].parentJoint
    ends = [
        (data.oMi[c.joint].act(end)[2] + 0.2 - c.radius, c.joint - 1)
        for c in braced.robot.link_capsules()
        if c.joint != skip
        for end in (c.a, c.b)
    ]
    expected = min(ends)
    assert value == pytest.approx(expected[0], abs=1e-12)
    assert link in {j for v, j in ends if v <= expected[0] + 1e-12}  # links meeting at a joint tie
    fd = central_difference(lambda x: link_clearance(braced.state(x))[0], q, 1e-6)
    np.testing.assert_allclose(link_clearance_gradient(state), fd, atol=1e-7)
    clearance = Clearance(braced)
    for d in clearance.links(q):
        fd = central_difference(lambda x, j=d.joint: {e.joint: e.clearance for e in clearance.links(x, False)}[j], q)
        np.testing.assert_allclose(d.gradient, fd, atol=1e-7)


def test_a_disk_far_from_the_arm_still_counts_every_link_and_a_huge_one_is_the_whole_plane() -> None:
    q = np.random.default_rng(0).uniform(-2.0, 2.0, 6)
    far = _braced(0.5, centre=(9.0, 9.0))  # no link is over the disk: each is seen from the rim or side
    found = {d.joint: d.clearance for d in Clearance(far).links(q)}
    brute = _sampled(far, q)
    assert set(found) == set(brute) == {c.joint - 1 for c in Clearance(far).capsules}
    for link, (value, _, kind) in brute.items():
        assert kind in ("rim", "side") and found[link] == pytest.approx(value, abs=1e-9)
    value, link = link_clearance(far.state(q))
    assert (value, link) == min((v, j) for j, v in found.items())
    assert 12.0 - 0.5 - 1.0 < value < np.inf
    whole = link_clearance(_braced(None).state(q))
    assert link_clearance(_braced(50.0).state(q)) == whole
    assert all(c.joint != 3 for c in Clearance(_braced(None)).capsules)  # the brace sits on l3 (joint 3)


def _chain_braced(surface: Surface, region: float | None, extent: float | None = None) -> BracedRobot:
    """The 7-joint random chain (brace frame on l3, collisions on l1..l4) braced on `surface`."""
    robot = Robot.from_urdf(_with_collisions(random_chain_urdf(7, seed=4, brace_link=3)), tip="tip")
    return BracedRobot(robot, Brace("brace", surface, region_radius=region, surface_radius=extent))


def _solid_distance(points: np.ndarray, centre: np.ndarray, normal: np.ndarray, r_max: float) -> np.ndarray:
    """Distance (m) of each point (k, 3) from the disk of radius r_max and the cylinder below it.

    Over the disk: the height (0 below the top). Beside it: below the plane the distance from the side, above
    it the distance from the rim circle's point nearest the point's lateral direction.
    """
    rel = points - centre
    height = rel @ normal
    lateral = rel - np.outer(height, normal)
    rho = np.linalg.norm(lateral, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rim = centre + r_max * lateral / rho[:, None]
    beside = np.where(height <= 0.0, rho - r_max, np.linalg.norm(points - rim, axis=1))
    return np.where(rho <= r_max, np.maximum(height, 0.0), beside)


def _sampled(braced: BracedRobot, q: np.ndarray, count: int = 2001) -> dict[int, tuple[float, float, str]]:
    """Brute force: link (chain order) → (least clearance of its capsules, that capsule's least t, kind).

    `count` points along each capsule segment placed by forward kinematics. Without a radius: the least
    height ("plane"). With one, if a point over the disk (lateral distance ≤ r_max) lies below the plane or a
    disk edge point between an inside and an outside sample does (found by bisection, 60 halvings): the least
    such height ("below"). Else the least distance from the solid, resampled (`count` points) between the best
    sample's neighbours; its kind is where that point is: "top" over the disk, "rim" beside and above it,
    "side" beside and below it.
    """
    model = braced.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    normal, centre = braced.brace.surface.normal, braced.brace.surface.point
    r_max = braced.brace.obstacle_radius
    skip = model.frames[braced.brace_id].parentJoint
    ts = np.linspace(0.0, 1.0, count)

    def lateral(p: np.ndarray) -> np.ndarray:
        rel = p - centre
        return np.linalg.norm(rel - np.outer(rel @ normal, normal), axis=1)

    out: dict[int, tuple[float, float, str]] = {}
    for cap in braced.robot.link_capsules():
        if cap.joint == skip:
            continue
        pa, pb = data.oMi[cap.joint].act(cap.a), data.oMi[cap.joint].act(cap.b)
        points = pa + np.outer(ts, pb - pa)
        height = (points - centre) @ normal
        if r_max is None:
            k = int(np.argmin(height))
            found = (float(height[k]) - cap.radius, float(ts[k]), "plane")
        else:
            inside = lateral(points) <= r_max
            cand_t, cand_h = list(ts[inside]), list(height[inside])
            for i in np.flatnonzero(inside[:-1] != inside[1:]):
                t_in, t_out = (ts[i], ts[i + 1]) if inside[i] else (ts[i + 1], ts[i])
                for _ in range(60):
                    mid = 0.5 * (t_in + t_out)
                    if lateral((pa + mid * (pb - pa))[None])[0] <= r_max:
                        t_in = mid
                    else:
                        t_out = mid
                cand_t.append(t_in)
                cand_h.append(float((pa + t_in * (pb - pa) - centre) @ normal))
            if cand_h and min(cand_h) < 0.0:
                k = int(np.argmin(cand_h))
                found = (cand_h[k] - cap.radius, cand_t[k], "below")
            else:
                k = int(np.argmin(_solid_distance(points, centre, normal, r_max)))
                fine = np.linspace(ts[max(k - 1, 0)], ts[min(k + 1, count - 1)], count)
                near = pa + np.outer(fine, pb - pa)
                dist = _solid_distance(near, centre, normal, r_max)
                k = int(np.argmin(dist))
                p = near[k]
                rho, h = lateral(p[None])[0], float((p - centre) @ normal)
                kind = "top" if rho <= r_max else "rim" if h > 0.0 else "side"
                found = (float(dist[k]) - cap.radius, float(fine[k]), kind)
        link = cap.joint - 1
        if link not in out or found[0] < out[link][0]:
            out[link] = found
    return out


def _edge_cases(seed: int) -> tuple[BracedRobot, np.ndarray]:
    """A q and a tilted plane with a 0.12 m region whose edge cuts a link 0.1 m below the plane."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.0, 2.0, 7)
    normal = rng.normal(size=3) + np.array([0.0, 0.0, 3.0])
    normal /= np.linalg.norm(normal)
    probe = _chain_braced(Surface([0.0, 0.0, -1.0], normal), None)
    model = probe.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    cap = Clearance(probe).capsules[rng.integers(3)]
    pa, pb = data.oMi[cap.joint].act(cap.a), data.oMi[cap.joint].act(cap.b)
    centre = pa + 0.7 * (pb - pa) + 0.1 * normal  # the disk's edge near the segment's middle, above it
    return _chain_braced(Surface(centre, normal), 0.12), q


@pytest.mark.parametrize("seed", range(12))
def test_clearance_over_a_region_matches_segments_sampled_brute_force(seed) -> None:
    braced, q = _edge_cases(seed)
    found = {d.joint: d.clearance for d in Clearance(braced).links(q, gradient=False)}
    brute = _sampled(braced, q)
    assert set(found) == set(brute) == {c.joint - 1 for c in Clearance(braced).capsules}
    for link, (value, _, _) in brute.items():
        assert found[link] == pytest.approx(value, abs=1e-9)
        assert found[link] <= value + 1e-12  # the samples can only miss the least point
    value, link = link_clearance(braced.state(q))
    assert (value, link) == min((v, j) for j, v in found.items())


def test_clearance_gradient_at_clip_points_on_the_region_edge_matches_finite_differences() -> None:
    interior = 0
    for seed in range(12):
        braced, q = _edge_cases(seed)
        clearance = Clearance(braced)
        brute = _sampled(braced, q)
        for d in clearance.links(q):
            fd = central_difference(
                lambda x, c=clearance, j=d.joint: {e.joint: e.clearance for e in c.links(x, False)}[j], q, 1e-6
            )
            np.testing.assert_allclose(d.gradient, fd, atol=2e-7)
            interior += brute[d.joint][2] == "below" and 1e-6 < brute[d.joint][1] < 1.0 - 1e-6
        fd = central_difference(lambda x, b=braced: link_clearance(b.state(x))[0], q, 1e-6)
        np.testing.assert_allclose(link_clearance_gradient(braced.state(q)), fd, atol=2e-7)
    assert interior >= 6  # in half the cases a link's least point is on the disk's edge, inside the segment


def _near_a_link(seed: int) -> tuple[BracedRobot, np.ndarray]:
    """A q and a tilted surface whose disk (radius 0.03–0.3 m) lies within about 0.2 m of a random link point."""
    rng = np.random.default_rng(100 + seed)
    q = rng.uniform(-2.0, 2.0, 7)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    probe = _chain_braced(Surface([0.0, 0.0, -1.0], normal), None)
    model = probe.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    caps = Clearance(probe).capsules
    cap = caps[rng.integers(len(caps))]
    pa, pb = data.oMi[cap.joint].act(cap.a), data.oMi[cap.joint].act(cap.b)
    centre = pa + rng.uniform(0.0, 1.0) * (pb - pa) + rng.normal(scale=0.12, size=3)
    return _chain_braced(Surface(centre, normal), None, float(rng.uniform(0.03, 0.3))), q


def test_distance_to_the_solid_matches_brute_force_and_its_gradient_finite_differences_on_top_rim_and_side() -> None:
    kinds: dict[str, int] = {}
    interior = 0
    for seed in range(40):
        braced, q = _near_a_link(seed)
        clearance = Clearance(braced)
        brute = _sampled(braced, q)
        for d in clearance.links(q):
            value, t, kind = brute[d.joint]
            assert d.clearance == pytest.approx(value, abs=1e-9)
            fd = central_difference(
                lambda x, c=clearance, j=d.joint: {e.joint: e.clearance for e in c.links(x, False)}[j], q, 1e-6
            )
            np.testing.assert_allclose(d.gradient, fd, atol=2e-7)
            kinds[kind] = kinds.get(kind, 0) + 1
            interior += kind != "below" and 1e-3 < t < 1.0 - 1e-3
        assert link_clearance(braced.state(q)) == min((d.clearance, d.joint) for d in clearance.links(q, False))
    # every way of being nearest is checked: over the top, from the rim circle, from the side, and penetration
    assert min(kinds.get(k, 0) for k in ("top", "rim", "side", "below")) >= 3, kinds
    assert interior >= 10  # least points inside the segment (not at an end)


@pytest.mark.parametrize("height", [0.0, 0.04])
def test_a_link_approaching_the_table_from_the_side_is_seen_until_it_touches_the_rim(height: float) -> None:
    q = np.random.default_rng(1).uniform(-1.0, 1.0, 7)
    probe = _chain_braced(Surface([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]), None)
    model = probe.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    cap = max(Clearance(probe).capsules, key=lambda c: np.linalg.norm(c.b - c.a))
    pa, pb = data.oMi[cap.joint].act(cap.a), data.oMi[cap.joint].act(cap.b)
    along = (pb - pa) / np.linalg.norm(pb - pa)
    normal = np.cross(along, [0.3, -0.5, 0.8])
    normal /= np.linalg.norm(normal)
    side = np.cross(normal, along)  # across the link, in the table's plane
    r_max, link = 0.2, cap.joint - 1
    seen = []
    for gap in (0.3, 0.1, cap.radius + 0.01, cap.radius):  # from the link's axis to the rim, in the plane
        centre = 0.5 * (pa + pb) - (r_max + gap) * side - height * normal  # the link `height` above the top
        braced = _chain_braced(Surface(centre, normal), None, r_max)
        found = {d.joint: d for d in Clearance(braced).links(q)}[link]
        assert found.clearance == pytest.approx(np.hypot(gap, height) - cap.radius, abs=1e-12)
        assert found.clearance == pytest.approx(_sampled(braced, q)[link][0], abs=1e-9)
        fd = central_difference(
            lambda x, b=braced: {e.joint: e.clearance for e in Clearance(b).links(x, False)}[link], q, 1e-7
        )
        np.testing.assert_allclose(found.gradient, fd, atol=2e-7)
        seen.append(found.clearance)
    assert seen[0] > seen[1] > seen[2] > 0.0  # finite and falling as the link comes in
    if height == 0.0:
        assert seen[-1] == pytest.approx(0.0, abs=1e-12)  # the capsule touches the rim


def test_inside_the_body_below_the_top_is_penetration_and_the_half_space_rule_is_unchanged() -> None:
    braced, q, link, radius, pa, pb = _mid_through(0.3)  # a plane 2 cm above the link's middle
    surface = braced.brace.surface
    below = surface.point - 0.3 * surface.normal  # the same plane, lowered 0.3 m: the link 0.28 m above it
    for centre, expected in ((surface.point, -0.02), (below, 0.28)):
        # a post far wider than the arm: the whole link is over it; and the whole plane
        for b in (
            _chain_braced(Surface(centre, surface.normal), None, 10.0),
            _chain_braced(Surface(centre, surface.normal), None),
        ):
            found = {d.joint: d.clearance for d in Clearance(b).links(q)}
            assert found[link] == pytest.approx(expected - radius, abs=1e-9)
            assert found[link] == pytest.approx(_sampled(b, q)[link][0], abs=1e-9)
    # a post thinner than the link is long, the link across its body 2 cm below the top: penetration
    post = _chain_braced(Surface(surface.point, surface.normal), None, 0.01)
    found = {d.joint: d.clearance for d in Clearance(post).links(q)}
    assert found[link] == pytest.approx(-0.02 - radius, abs=1e-9)
    assert _sampled(post, q)[link][2] == "below"
    # exactly on the plane (h = 0 over the disk): touching, the capsule's radius inside
    level = _chain_braced(Surface(0.5 * (pa + pb), surface.normal), None, 0.05)
    assert {d.joint: d.clearance for d in Clearance(level).links(q)}[link] == pytest.approx(-radius, abs=1e-12)
    assert braced.brace.obstacle_radius == braced.brace.region_radius
    assert _chain_braced(surface, None).brace.obstacle_radius is None


def _mid_through(
    region_scale: float, tilt: float = 0.0
) -> tuple[BracedRobot, np.ndarray, int, float, np.ndarray, np.ndarray]:
    """A plane 2 cm above a link's middle, its disk (radius region_scale · length) about there.

    The plane is parallel to the link, or with `tilt` its normal leans that much (of a unit) along the link.
    """
    q = np.random.default_rng(1).uniform(-1.0, 1.0, 7)
    probe = _chain_braced(Surface([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]), None)
    model = probe.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    cap = max(Clearance(probe).capsules, key=lambda c: np.linalg.norm(c.b - c.a))
    pa, pb = data.oMi[cap.joint].act(cap.a), data.oMi[cap.joint].act(cap.b)
    normal = np.cross(pb - pa, [0.3, -0.5, 0.8])
    normal = normal / np.linalg.norm(normal) + tilt * (pb - pa) / np.linalg.norm(pb - pa)
    normal /= np.linalg.norm(normal)
    centre = 0.5 * (pa + pb) + 0.02 * normal
    braced = _chain_braced(Surface(centre, normal), region_scale * float(np.linalg.norm(pb - pa)))
    return braced, q, cap.joint - 1, cap.radius, pa, pb


def test_a_link_whose_middle_passes_through_the_disk_between_ends_outside_it_is_caught() -> None:
    for tilt in (0.0, 0.05):
        braced, q, link, radius, pa, pb = _mid_through(0.3, tilt)
        surface, r_max = braced.brace.surface, braced.brace.region_radius
        for end in (pa, pb):  # both ends lie beyond the disk: the plane under them is no obstacle
            rel = end - surface.point
            assert np.linalg.norm(rel - surface.normal * (surface.normal @ rel)) > r_max
        found = {d.joint: d for d in Clearance(braced).links(q)}
        assert found[link].clearance == pytest.approx(_sampled(braced, q)[link][0], abs=1e-9)
        assert link_clearance(braced.state(q))[0] <= found[link].clearance <= -0.02 - radius + 1e-9
        if tilt == 0.0:  # parallel: the whole clipped segment lies 2 cm beneath the plane
            assert found[link].clearance == pytest.approx(-0.02 - radius, abs=1e-9)
        else:  # the lower clip point is the least: a smooth function of q
            fd = central_difference(
                lambda x, b=braced, j=link: {e.joint: e.clearance for e in Clearance(b).links(x, False)}[j], q, 1e-6
            )
            np.testing.assert_allclose(found[link].gradient, fd, atol=2e-7)


def test_segments_along_the_normal_grazing_the_cylinder_or_of_zero_length_give_finite_clearance() -> None:
    braced, q, _, _, pa, pb = _mid_through(0.5, 0.05)  # the disk's edge passes through both ends
    surface = braced.brace.surface
    along = _chain_braced(Surface(pb - 0.05 * (pb - pa), (pb - pa) / np.linalg.norm(pb - pa)), 0.1)
    # the cylinder's side touches the segment's line: the capsule counts at one clip point
    side = np.cross(pb - pa, surface.normal)
    side /= np.linalg.norm(side)
    graze = _chain_braced(Surface(0.5 * (pa + pb) + 0.1 * side + 0.02 * surface.normal, surface.normal), 0.1)
    for b in (braced, along, graze):
        found = Clearance(b).links(q)
        brute = _sampled(b, q)
        for d in found:
            assert np.all(np.isfinite(d.gradient)) and np.isfinite(d.clearance)
            assert d.clearance == pytest.approx(brute[d.joint][0], abs=1e-6)
        value, _ = link_clearance(b.state(q))
        assert np.isfinite(value) and np.all(np.isfinite(link_clearance_gradient(b.state(q))))
    # a link along the normal on the rim, across the plane: penetration by its lower end's depth
    length = float(np.linalg.norm(pb - pa))
    cap_link = max(Clearance(braced).capsules, key=lambda c: np.linalg.norm(c.b - c.a))
    for r_max in np.linspace(0.05, 0.3, 11):
        rim = _chain_braced(Surface(0.5 * (pa + pb) + r_max * side, (pb - pa) / length), None, float(r_max))
        found = {d.joint: d.clearance for d in Clearance(rim).links(q)}
        assert found[cap_link.joint - 1] == pytest.approx(-0.5 * length - cap_link.radius, abs=1e-12)
    # the sphere capsule of l2 (a = b) over a disk about it counts as its centre
    model = braced.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    sphere = next(c for c in Clearance(braced).capsules if c.link == "l2")
    centre = data.oMi[sphere.joint].act(sphere.a)
    ball = _chain_braced(Surface(centre - [0.01, 0.0, 0.3], [0.0, 0.0, 1.0]), 0.02)
    got = {d.joint: d.clearance for d in Clearance(ball).links(q)}
    assert got[sphere.joint - 1] == pytest.approx(0.3 - sphere.radius, abs=1e-12)


def test_the_clearance_cache_lets_braced_robots_go() -> None:
    robot = load_model("paper-robot").with_point_frame("b", "link2", [0.1, 0.0, 0.0])
    refs = []
    for k in range(CACHE_SIZE + 3):
        braced = BracedRobot(robot, Brace("b", Surface([0.0, 0.0, -1.0 - k], [0.0, 0.0, 1.0])))
        link_clearance(braced.state(np.zeros(robot.n)))
        refs.append(weakref.ref(braced))
        del braced
    gc.collect()
    assert all(r() is None for r in refs[:3])  # the oldest are no longer held by the cache


def test_several_braces_each_surface_an_obstacle_without_its_braced_link_and_pad_against_brute_force() -> None:
    from bracekit import load_scenario

    braced = load_scenario("two-braces").braced
    robot = braced.robot
    clearance = Clearance(braced)
    assert clearance.mesh is None and len(clearance.surfaces) == 2
    # the wall pad sits at link 9's origin: the capsule of the link before it ends at the pad, left out
    wall_joint = int(robot.model.frames[braced.brace_ids[1]].parentJoint)
    pad_link = int(robot.model.parents[wall_joint]) - 1
    assert pad_link not in {c.joint - 1 for c in clearance.surfaces[1].capsules}
    assert pad_link in {c.joint - 1 for c in clearance.surfaces[0].capsules}
    rng = np.random.default_rng(5)
    for q in [robot.neutral(), *(rng.uniform(robot.lower, robot.upper) for _ in range(3))]:
        brute: dict[int, float] = {}
        for i, brace in enumerate(braced.braces):
            for link, (value, _, _) in _sampled(BracedRobot(robot, brace), q).items():
                if i == 1 and link == pad_link:
                    continue
                brute[link] = min(brute.get(link, np.inf), value)
        found = {d.joint: d.clearance for d in clearance.links(q, False)}
        assert set(found) == set(brute)
        for link, value in brute.items():
            assert found[link] == pytest.approx(value, abs=1e-7)
        assert clearance.minimum(q) == min((v, j) for j, v in found.items())
        assert link_clearance(braced.state(q)) == clearance.minimum(q)
    qs = [robot.neutral(), *(rng.uniform(robot.lower, robot.upper) for _ in range(20))]
    same_least(clearance, qs, *clearance.minima(qs))  # the path at once (compiled): the same to 1e-12 m


@pytest.mark.parametrize("region", [None, 0.3])
def test_the_clearances_of_a_path_at_once_are_those_of_each_configuration(region) -> None:
    from bracekit.kinematics.clearance import link_clearances

    braced = _braced(region)
    qs = list(np.random.default_rng(7).uniform(-2.0, 2.0, (40, braced.n)))
    values, joints = link_clearances(braced, qs)  # compiled over the path: the same to 1e-12 m
    same_least(Clearance(braced), qs, values, joints)
    assert [link_clearance(braced.state(q)) for q in qs] == [Clearance(braced).minimum(q) for q in qs]
    assert link_clearances(braced, [])[0].size == 0
