"""Footprints: the vertical projection of a primitive, and an object's footprints prepared once per pose."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from hoi_tutorial.world import primitives
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.scenes import FOOTPRINT_BAND

TILT = primitives.rotation_x(0.5) @ primitives.rotation_z(0.7)
PARTS = {
    "a tilted box": primitives.box((0.2, -0.1, 0.6), (0.3, 0.15, 0.1), TILT),
    "a tilted capsule": primitives.capsule_between((0.0, 0.0, 0.3), (0.4, 0.2, 0.8), 0.08),
    "an upright cylinder": primitives.cylinder((0.1, 0.3, 0.4), 0.2, 0.3),
    "a sphere": primitives.sphere((-0.2, 0.1, 0.5), 0.15),
}


@pytest.mark.parametrize("name", list(PARTS))
def test_a_footprint_distance_is_the_distance_to_the_parts_shadow(name):
    """Against the shadow of the solid sampled densely: points inside the part (its SDF), dropped to the floor."""
    part = PARTS[name]
    rng = np.random.default_rng(0)
    lo, hi = primitives.primitive_bounds(part)
    points = rng.uniform(lo, hi, (200000, 3))
    shadow = points[primitives.PrimitiveSet([part]).sdf(points) <= 0][:, :2]
    assert len(shadow) > 5000
    xy = rng.uniform(lo[:2] - 0.3, hi[:2] + 0.3, (300, 2))
    sampled = cKDTree(shadow).query(xy)[0]
    exact = primitives.footprint_distance(part, xy)
    assert np.all(exact <= sampled + 1e-9)  # every sample lies in the footprint
    assert np.all(sampled - exact < 0.02)  # and they cover it to within their spacing
    assert 0 < np.mean(exact == 0) < 1
    prepared = primitives.footprint(part)
    np.testing.assert_array_equal(prepared.distance(xy), exact)
    above = (hi[2] + 0.1, hi[2] + 0.5)  # a band the part does not reach: no footprint
    assert primitives.footprint(part, above).kind == "empty"
    assert np.all(np.isinf(primitives.footprint_distance(part, xy, above)))


def test_an_objects_footprints_are_prepared_once_for_its_pose():
    obj = make_object("armchair", 0).placed(1.0, 1.0, 0.3)
    xy = np.random.default_rng(1).uniform(0.0, 2.0, (200, 2))

    def distances(o):
        return np.minimum.reduce([part.distance(xy) for part in o.footprints(FOOTPRINT_BAND)])

    def direct(o):
        return np.minimum.reduce([primitives.footprint_distance(p, xy, FOOTPRINT_BAND) for p in o.world_primitives()])

    assert obj.footprints(FOOTPRINT_BAND) is obj.footprints(FOOTPRINT_BAND)  # prepared once
    before = distances(obj)
    np.testing.assert_array_equal(before, direct(obj))
    moved = obj.with_pose(obj.pose @ primitives.rigid_transform(np.eye(3), (0.4, 0.0, 0.0)))
    np.testing.assert_array_equal(distances(moved), direct(moved))  # a copy prepares its own
    np.testing.assert_array_equal(distances(obj), before)
    obj.pose[:2, 3] += 0.5  # moved in place: prepared again for the new pose
    np.testing.assert_array_equal(distances(obj), direct(obj))
    assert not np.array_equal(distances(obj), before)


def test_the_row_norms_are_numpys_bit_for_bit():
    d = np.random.default_rng(2).normal(scale=[1e-3, 1e3], size=(5000, 2))
    assert primitives._row_norms(d).tobytes() == np.linalg.norm(d, axis=1).tobytes()
